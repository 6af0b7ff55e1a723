"""How a use case tells its caller what it is doing, without printing.

The CLI renders these calls as status lines and progress bars (``cli/``); the Python
API passes :data:`SILENT`, which turns warnings into :mod:`warnings` and drops the
rest; a notebook may pass its own object with the same five methods.
"""

from __future__ import annotations

import os
import sys
import warnings
from types import FrameType
from typing import Protocol, runtime_checkable

__all__ = ["SILENT", "Progress", "Silent"]


@runtime_checkable
class Progress(Protocol):
    """The callback protocol of every use case."""

    def message(self, text: str) -> None:
        """A status line ("0811: 1,203 orders due, 1,180 planned")."""

    def warning(self, text: str) -> None:
        """Something the user should know even in a quiet run."""

    def start(self, label: str, total: int, unit: str) -> None:
        """A long step begins: ``total`` ``unit`` (windows, days, episodes) to go;
        ``total`` 0: a step of unknown length (segmenting)."""

    def advance(self, text: str = "") -> None:
        """One more ``unit`` of the step begun last is done; ``text`` says what it was
        (a log shows it where no progress bar is drawn)."""

    def finish(self) -> None:
        """The step begun last is over (also after an error or an interrupt)."""


class Silent:
    """Says nothing; warnings become :func:`warnings.warn` (the Python API's)."""

    def message(self, text: str) -> None:
        return None

    def warning(self, text: str) -> None:
        from ..errors import keyword, spelled

        # Said at the caller's line (``day = api.replay_day(...)``), not inside marops,
        # naming an option by its keyword (marops_cli/errors.py).
        warnings.warn(spelled(text, keyword), stacklevel=_caller_level())

    def start(self, label: str, total: int, unit: str) -> None:
        return None

    def advance(self, text: str = "") -> None:
        return None

    def finish(self) -> None:
        return None


def _caller_level() -> int:
    """The ``stacklevel`` of the first frame outside the package (for ``warning``)."""
    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep
    frame: FrameType | None = sys._getframe(2)
    level = 2
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(package):
        frame, level = frame.f_back, level + 1
    return level


SILENT: Progress = Silent()
"""The progress of a call that reports nothing."""
