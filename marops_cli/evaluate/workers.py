"""Jobs over worker processes or a Dask cluster, for ``evaluate`` and multi-day
``replay-day`` alike (docs/decisions.md, "Workers").

A :class:`Work` is everything its jobs need (the replayed days' rows, the depots, the
method), sent to each worker once; a worker sets itself up from it (one OpenMP/BLAS/
torch thread, :meth:`Work.setup`) before its first job and reuses that set-up for every
later job. Each job carries its ``index``; outcomes come back as jobs finish, and the
caller puts them in order and writes them, so no result depends on where a job ran.

Local workers are forked from a *fork server* that has already imported the planner
(and torch, when the work runs an actor), so a worker starts in milliseconds instead of
re-importing the stack; :func:`warm_up` starts that server early, while the parent is
still reading the file. Where there is no fork server (Windows), workers are spawned.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import sys
import threading
import uuid
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any, Protocol

from ..errors import MaropsError

Outcome = tuple[int, Any, str | None, int]
"""A job's index, then its result, or the message and exit code of its error."""

# What a fork server imports before it forks the first worker (``warm_up``).
PRELOAD = (
    "marops_cli.evaluate.runner",
    "marops_cli.evaluate.workers",
    "marops_cli.sim.days",
    "marops_cli.io.tables",
    "pyarrow.parquet",
)
ACTOR_PRELOAD = ("torch", "marops_cli.policies.torchscript")


class Job(Protocol):
    @property
    def index(self) -> int: ...


class Work(Protocol):
    """What every job of a run needs; sent to each worker once."""

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


def one_thread() -> None:
    """One OpenMP/BLAS/torch thread in this process: the workers already fill the cores,
    and threads on top only oversubscribe them."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1)  # the libraries loaded so far (numpy's BLAS)
    os.environ["OMP_NUM_THREADS"] = "1"  # and those loaded later (torch reads it)
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(1)


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


_WARM: set[str] = set()


def warm_up(actor: bool = False) -> None:
    """Start the fork server now, importing the planner (and torch for an ``actor``), so
    its imports overlap with the parent's own work; later pools fork from it. Harmless
    where there is none, or when it runs already."""
    ctx = _context()
    if ctx.get_start_method() != "forkserver" or _WARM:
        return
    modules = [*PRELOAD, *(ACTOR_PRELOAD if actor else ())]
    ctx.set_forkserver_preload(modules)
    from multiprocessing import forkserver

    forkserver.ensure_running()
    _WARM.update(modules)


# Per-process state of a pool's worker (set once by the initializer).
_WORK: list[Work] = []


def _init(work: Work) -> None:
    # Ctrl-C reaches the whole process group: the parent stops the pool and keeps what
    # finished; workers ignore it, so no worker prints a traceback.
    if mp.current_process().name != "MainProcess":
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        _die_with_parent()
        one_thread()
    work.setup()
    _WORK[:] = [work]


def run_safe(work: Work, job: Job) -> Outcome:
    """``work.run(job)`` as an outcome: library errors cross the process boundary as
    text and are raised again by the parent as one line."""
    try:
        return job.index, work.run(job), None, 0
    except MaropsError as exc:
        return job.index, None, str(exc), exc.exit_code


def _run_pooled(job: Job) -> Outcome:
    return run_safe(_WORK[0], job)


@contextmanager
def pool_outcomes(work: Work, todo: Sequence[Job], workers: int) -> Iterator[Iterator[Outcome]]:
    """Outcomes of ``todo`` from this process (one worker) or a local pool, as they finish."""
    if workers <= 1 or len(todo) <= 1:
        _init(work)
        yield (run_safe(work, job) for job in todo)
        return
    warm_up(actor="torch" in sys.modules)  # the parent loaded an actor: so will workers
    pool = _context().Pool(min(workers, len(todo)), initializer=_init, initargs=(work,))
    try:
        yield pool.imap_unordered(_run_pooled, todo, chunksize=1)
    finally:
        pool.terminate()
        pool.join()


_ONE_AT_A_TIME = threading.Lock()  # per cluster worker process
_SET_UP: dict[str, Any] = {}  # per cluster worker process: the work it set up last


def _cluster_job(job: Job, work: Work) -> Outcome:
    with _ONE_AT_A_TIME:
        if _SET_UP.get("work") is not work:
            problem = work.refuse()
            if problem is not None:
                return job.index, None, problem, 2
            one_thread()
            work.setup()
            _SET_UP["work"] = work
        return run_safe(work, job)


@contextmanager
def cluster_outcomes(
    work: Work, todo: Sequence[Job], scheduler: str, workers: int, name: str
) -> Iterator[Iterator[Outcome]]:
    """Outcomes of ``todo`` run on the Dask cluster at ``scheduler`` (``local``: one of
    ``workers`` processes here), as they finish; submitted in job order, the work
    scattered to every worker once."""
    from .cluster import connect, require_distributed

    distributed = require_distributed()
    with connect(scheduler, workers) as client:
        context = client.scatter(work, broadcast=True, hash=False)
        key = f"marops-{name}-{uuid.uuid4().hex[:8]}"
        futures = [
            client.submit(_cluster_job, job, context, key=(key, job.index), pure=False)
            for job in todo
        ]
        try:
            yield (outcome for _, outcome in distributed.as_completed(futures, with_results=True))
        finally:
            client.cancel(futures)


@contextmanager
def outcomes(
    work: Work, todo: Sequence[Job], workers: int, scheduler: str | None, name: str
) -> Iterator[Iterator[Outcome]]:
    """Outcomes of ``todo``: on the cluster at ``scheduler``, else on ``workers`` local
    processes (this one when 1)."""
    if not todo:
        yield iter(())
    elif scheduler is not None:
        with cluster_outcomes(work, todo, scheduler, workers, name) as out:
            yield out
    else:
        with pool_outcomes(work, todo, workers) as out:
            yield out
