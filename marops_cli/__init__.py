"""marops: operations planner for drone last-mile delivery (the MAR-OPS method)."""

import os
import sys
from importlib.metadata import PackageNotFoundError, version

# Torch's BLAS on the code path every x86 processor runs alike, so trained weights are
# the same bytes on any machine and with any number of workers: set before torch loads,
# never after (workers/threads.py, portable_blas, says why; docs/decisions.md, "Same
# results").
if "torch" not in sys.modules:
    os.environ.setdefault("MKL_CBWR", "COMPATIBLE")

try:
    __version__ = version("marops")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+local"

# The Python API is ``from marops_cli import api``: the commands as functions. They are
# not re-exported here because ``marops_cli.segment`` and ``marops_cli.evaluate`` are
# subpackages, whose import would shadow functions of those names; nor is ``api``
# imported here, so that the stages below it can read ``__version__`` (imports run
# one way, pyproject's import-linter contract).
__all__ = ["__version__"]
