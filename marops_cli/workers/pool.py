"""Local worker processes, forked from a fork server, each set up once from the run's
:class:`~.work.Work` (docs/decisions.md, "Workers").

Workers are forked from a *fork server* that has already imported what the work needs
(:attr:`Work.preload <.work.Work.preload>`: the planner, torch for an actor), so a
worker starts in milliseconds instead of re-importing the stack; :func:`warm_up` starts
that server early, while the parent is still reading the file. Where there is no fork
server (Windows), workers are spawned.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import sys
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from ..errors import InputError, RunError, option
from .threads import one_thread
from .work import Job, Outcome, Work, run_safe


def _die_with_parent() -> None:
    """A worker whose parent is killed (kill -9) is killed too, not left running (Linux)."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes

    try:
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    if os.getppid() == 1:  # the parent died before the call
        os._exit(1)


def _context() -> Any:
    """Fork server where the platform has one, else spawn: never a plain fork of the
    parent, whose Arrow and solver threads would be copied half-way."""
    method = "forkserver" if "forkserver" in mp.get_all_start_methods() else "spawn"
    return mp.get_context(method)


_server_started = False

_MAIN_GUARD = (
    "a worker imports the script that started it, so a script runs marops under "
    '`if __name__ == "__main__":` (or with one worker)'
)


def not_in_a_starting_worker() -> None:
    """A worker importing the main script as it starts (as Python's multiprocessing
    does), asked there for workers of its own, stops at once and quietly (exit 1): the
    script it imports has no main guard, which the parent says, once, as its pool finds
    its workers stopped. An exception here would print a traceback per worker before it."""
    if getattr(mp.current_process(), "_inheriting", False):
        raise SystemExit(1)


def _main_importable() -> None:
    """Stop before starting workers when the main script is no file they can import
    (``python - < script.py`` names it ``<stdin>``): Python's multiprocessing has each
    worker import it by its path, which fails, guard or not. A notebook's or
    ``python -c``'s main has no file to import, and needs none."""
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if getattr(main, "__spec__", None) is not None or not isinstance(path, str):
        return
    full = os.path.join(getattr(mp.process, "ORIGINAL_DIR", None) or "", path)
    if not os.path.isfile(full):
        raise RunError(
            f"the script that started marops ({path}) is no file a worker process can "
            "import, as each does: save it to a file and run that, or use one worker"
        )


@contextmanager
def sigint_ignored() -> Iterator[None]:
    """SIGINT ignored within (in the main thread; elsewhere nothing changes). A process
    started meanwhile starts with SIGINT ignored, and Python keeps it so."""
    try:
        old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old if old is not None else signal.SIG_DFL)


_HELD = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def signals_held() -> Iterator[None]:
    """Ctrl-C and SIGTERM held within and delivered on the way out, as the run handles
    them (KeyboardInterrupt, :class:`~marops_cli.io.atomic.Terminated`): so this process
    never stops half-way through handing a worker its start-up data, which the worker
    would report with a traceback (``pickle data was truncated``), nor through making a
    temporary or renaming a set of files into place (marops_cli/io/atomic.py). Their
    handlers are swapped, not the signals blocked: a blocked signal goes to another of
    the process's threads (Arrow's, OpenMP's), and Python runs its handler in the main
    thread all the same. In the main thread only; elsewhere nothing changes (no handler
    runs there)."""
    got: list[int] = []

    def hold(signum: int, frame: object) -> None:
        got.append(signum)

    try:
        old = {sig: signal.signal(sig, hold) for sig in _HELD}
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler if handler is not None else signal.SIG_DFL)
        for signum in dict.fromkeys(got):
            signal.raise_signal(signum)


def warm_up(modules: Sequence[str]) -> None:
    """Start the fork server now, importing ``modules`` (a work's :attr:`~.work.Work.preload`),
    so its imports overlap with the parent's own work; later pools fork from it. Harmless
    where there is none, or when it runs already.

    The server starts with SIGINT ignored, so Ctrl-C (which reaches the whole process
    group) neither stops its imports with a traceback nor reaches a worker it forks
    before the worker is set up: the parent alone handles it, and stops the workers."""
    global _server_started
    not_in_a_starting_worker()
    ctx = _context()
    if ctx.get_start_method() != "forkserver":
        return
    if not _server_started:
        ctx.set_forkserver_preload(list(modules))
        _server_started = True
    from multiprocessing import forkserver

    with sigint_ignored():  # for the few milliseconds of its start, if it must (re)start
        forkserver.ensure_running()


# Per-process state of a pool's worker (set once by the initializer).
_WORK: list[Work] = []


MAX_WORKERS = 256
"""The most local worker processes a run starts (results never depend on how many)."""


def check_workers(workers: int) -> None:
    """Refuse a count of worker processes below 1 or above :data:`MAX_WORKERS` (a
    mistyped count, not a machine of that many cores), before any work."""
    if not 1 <= workers <= MAX_WORKERS:
        raise InputError(f"{option('workers')} expects 1 to {MAX_WORKERS}, got {workers}")


PER_CPU = 4
"""The most local worker processes a run starts per CPU it may use (:func:`local_workers`):
each is single-threaded, so more only hold more memory (each its copy of the days)."""


def usable_cpus() -> int:
    """The CPUs this process may run on: its CPU affinity where the system keeps one (a
    container's or ``taskset``'s share), else the machine's count."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except (AttributeError, OSError):  # no affinity (macOS, Windows)
        return max(os.cpu_count() or 1, 1)


def local_workers(workers: int) -> int:
    """How many of ``workers`` local processes a run starts: at most :data:`PER_CPU` per
    usable CPU. The results never depend on it, so a command asking more than this
    machine runs well still runs, to the same bytes."""
    return min(workers, PER_CPU * usable_cpus())


def workers_note(workers: int, scheduler: str | None = None, jobs: int | None = None) -> str | None:
    """The one-line warning of a run asking more local processes than it starts
    (:func:`local_workers`), None when it starts them all. A run of ``jobs`` jobs here
    starts no more processes than jobs; a remote Dask cluster's workers are its own
    (``scheduler`` neither None nor ``local``, as workers/cluster.py names it)."""
    if scheduler not in (None, "local"):
        return None
    asked = min(workers, jobs) if jobs is not None and scheduler is None else workers
    if (start := local_workers(asked)) == asked:
        return None
    return (
        f"{option('workers')} {workers} is more than {PER_CPU} per CPU this process may use "
        f"({usable_cpus()}): {start} worker process{'es' if start > 1 else ''} run (the results "
        "are the same)"
    )


def _init(work: Work) -> None:
    # Ctrl-C reaches the whole process group: the parent stops the pool and keeps what
    # finished; workers ignore it, so no worker prints a traceback.
    if mp.current_process().name != "MainProcess":
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        _die_with_parent()
        one_thread()
    work.setup()
    _WORK[:] = [work]


def _run_pooled(job: Job) -> Outcome:
    return run_safe(_WORK[0], job)


class LocalPool:
    """``work``'s jobs on ``workers`` local processes (at most :func:`local_workers`),
    each set up once from ``work``; this process itself when ``workers`` is 1. A context
    manager: leaving it (Ctrl-C included) stops the workers."""

    def __init__(self, work: Work, workers: int) -> None:
        check_workers(max(workers, 1))
        workers = local_workers(workers)
        self.work = work
        self._pool: Any = None
        if workers <= 1:
            _init(work)
            return
        not_in_a_starting_worker()
        _main_importable()
        warm_up(work.preload)
        try:
            with signals_held():  # a Ctrl-C meanwhile stops the started pool below
                self._pool = _context().Pool(workers, initializer=_init, initargs=(work,))
        except (BrokenPipeError, EOFError, ConnectionResetError) as exc:
            self.close(failed=True)
            # from None: the broken pipe's traceback above the reason adds nothing.
            raise RunError(
                f"the worker processes stopped as they started ({exc}): {_MAIN_GUARD}"
            ) from None
        except BaseException:
            self.close(failed=True)
            raise

    def outcomes(self, jobs: Iterable[Job]) -> Iterator[Outcome]:
        """The outcomes of ``jobs`` as they finish."""
        if self._pool is None:
            return (run_safe(self.work, job) for job in jobs)
        return self._pool.imap_unordered(_run_pooled, jobs, chunksize=1)

    def results(self, jobs: Sequence[Job]) -> list[Any]:
        """The results of ``jobs`` in their order (their indices are distinct), whichever
        worker ran each; a failed job is raised as one line."""
        found = {outcome.index: outcome.value() for outcome in self.outcomes(jobs)}
        return [found[job.index] for job in jobs]

    def close(self, failed: bool = False) -> None:
        """Stop the workers: as the pool stops them after its work, or by :func:`_abandon`
        when an error, Ctrl-C or a signal stopped the work (``failed``) or a worker died."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        if failed or any(proc.exitcode is not None for proc in pool._pool):
            _abandon(pool)
        else:
            pool.terminate()
            pool.join()

    def __enter__(self) -> LocalPool:
        return self

    def __exit__(self, kind: object, *exc: object) -> None:
        self.close(failed=kind is not None)


def _abandon(pool: Any) -> None:
    """Stop ``pool`` without ``Pool.terminate()``: that waits on the pool's queue locks,
    and a worker killed from outside while it held one (a SIGTERM to the whole process
    group, as ``timeout``, ``kill -- -PGID`` and systemd send) left it held for ever, so
    the run hung. The pool stops replacing workers, every worker is killed (SIGKILL: its
    job's result is not wanted) and reaped, and the pool's finaliser is cancelled, so
    nothing waits on those locks, at exit either; its other threads are daemons."""
    from multiprocessing.pool import TERMINATE, Pool

    if not isinstance(pool, Pool):  # another kind of pool stops as it stops itself
        pool.terminate()
        pool.join()
        return
    inner: Any = pool  # the pool's internals: its threads' states, queues and workers
    inner._state = TERMINATE
    inner._worker_handler._state = TERMINATE
    inner._change_notifier.put(None)  # wakes the worker handler, which then ends
    # Any worker it was starting in place of a dead one is started before it ends, and
    # killed below with the others (one killed half-started printed a traceback).
    inner._worker_handler.join(timeout=10)
    for proc in list(inner._pool):
        if proc.exitcode is None:
            proc.kill()
    for proc in list(inner._pool):
        proc.join(timeout=10)
    inner._terminate.cancel()
