"""The command line's side of the use cases' progress (marops_cli/app/progress.py): a
rich progress bar (or a spinner for a step of unknown length) on a terminal, the status
lines on stderr otherwise; nothing with ``--quiet`` or ``--json`` but warnings."""

from __future__ import annotations

from typing import Any

from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    ProgressColumn,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from ..errors import spelled
from .common import PLAIN, STATE, console, info, is_terminal, one_line, warn


class Terminal:
    """Renders one use case's :class:`~marops_cli.app.progress.Progress` calls;
    ``remaining`` adds the time left to the bar (long runs: evaluate)."""

    def __init__(self, remaining: bool = False) -> None:
        self._remaining = remaining
        self._bar: Progress | None = None
        self._task: Any = None
        self._status: Any = None

    def message(self, text: str) -> None:
        info(text)

    def warning(self, text: str) -> None:
        warn(spelled(text))  # an option named by its flag (marops_cli/errors.py)

    def start(self, label: str, total: int, unit: str) -> None:
        """A bar of ``total`` steps on a terminal; ``total`` 0: a spinner."""
        self.finish()
        quiet = STATE["quiet"] or STATE["json"]
        if total == 0:
            if not (PLAIN or quiet):
                self._status = console.status(one_line(label))
                self._status.__enter__()
            return
        if quiet or not is_terminal():
            return
        columns: list[ProgressColumn] = [
            TextColumn(one_line(label), markup=False),
            BarColumn(),
            MofNCompleteColumn(),
            TimeElapsedColumn(),
        ]
        if self._remaining:
            columns.append(TimeRemainingColumn())
        self._bar = Progress(*columns, console=console, transient=True)
        self._task = self._bar.add_task(unit, total=total)
        self._bar.start()

    def advance(self, text: str = "") -> None:
        """The bar moves on; without one, ``text`` is the step's log line."""
        if self._bar is not None:
            self._bar.advance(self._task)
        elif text and self._status is None:
            info(text)

    def finish(self) -> None:
        if self._bar is not None:
            self._bar.stop()
            self._bar = None
        if self._status is not None:
            self._status.__exit__(None, None, None)
            self._status = None
