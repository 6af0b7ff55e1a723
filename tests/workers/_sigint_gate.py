"""Imported by a fork server as it starts (a work's preload, tests/workers/test_pool.py):
it says so in the file ``$MAROPS_TEST_GATE_READY``, with the SIGINT handler it found, and
waits until the file ``$MAROPS_TEST_GATE_GO`` exists, so a test can press Ctrl-C while
the server imports."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

_ready, _go = os.environ.get("MAROPS_TEST_GATE_READY"), os.environ.get("MAROPS_TEST_GATE_GO")
if _ready and _go:
    handler = signal.getsignal(signal.SIGINT)
    Path(_ready).write_text("ignored" if handler is signal.SIG_IGN else str(handler))
    deadline = time.monotonic() + 120
    while not Path(_go).exists() and time.monotonic() < deadline:
        time.sleep(0.01)
