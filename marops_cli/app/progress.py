"""How a use case tells its caller what it is doing, without printing.

The CLI renders these calls as status lines and progress bars (``cli/``); the Python
API passes :data:`SILENT`, which turns warnings into :mod:`warnings` and drops the
rest; a notebook may pass its own object with the same five methods.
"""

from __future__ import annotations

import warnings
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
        warnings.warn(text, stacklevel=2)

    def start(self, label: str, total: int, unit: str) -> None:
        return None

    def advance(self, text: str = "") -> None:
        return None

    def finish(self) -> None:
        return None


SILENT: Progress = Silent()
"""The progress of a call that reports nothing."""
