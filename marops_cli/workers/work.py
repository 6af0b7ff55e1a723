"""What the worker pools run: a :class:`Work` sent to each worker once, typed jobs that
carry their ``index``, and each job's :class:`Outcome`."""

from __future__ import annotations

from typing import Any, NamedTuple, Protocol

from ..errors import InputError, MaropsError, RunError


class Job(Protocol):
    """One job of a run; ``index`` puts its outcome back in order."""

    @property
    def index(self) -> int: ...


class Work(Protocol):
    """What every job of a run needs; sent to each worker once."""

    @property
    def preload(self) -> tuple[str, ...]:
        """Modules a local worker imports before its first job: the fork server imports
        them once, so a worker starts without re-importing them."""
        ...

    def setup(self) -> None:
        """Once per process, before its first job (register methods, clear caches)."""
        ...

    def run(self, job: Any) -> Any:
        """One job's result (picklable); a :class:`MaropsError` is its one-line failure."""
        ...

    def refuse(self) -> str | None:
        """On a cluster worker, why this machine must not run the work (another actor
        file, say), or None."""
        ...


class Outcome(NamedTuple):
    """A job's index, then its result, or the message and exit code of its error."""

    index: int  # type: ignore[assignment]  # shadows tuple.index; read by name
    result: Any
    error: str | None
    code: int

    def value(self) -> Any:
        """The result, or the job's error raised again as one line (exit code 2: the
        input's fault)."""
        if self.error is not None:
            raise InputError(self.error) if self.code == 2 else RunError(self.error)
        return self.result


def run_safe(work: Work, job: Job) -> Outcome:
    """``work.run(job)`` as an outcome: library errors cross the process boundary as
    text and are raised again by the parent as one line."""
    try:
        return Outcome(job.index, work.run(job), None, 0)
    except MaropsError as exc:
        return Outcome(job.index, None, str(exc), exc.exit_code)
