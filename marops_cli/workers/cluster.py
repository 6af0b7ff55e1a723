"""The Dask cluster behind ``--scheduler ADDRESS|local`` of ``evaluate`` and
``replay-day`` (README.md "Sweeps on a cluster").

``distributed`` is an optional extra (``pip install 'marops[cluster]'``), imported only
here and only when a scheduler is asked for. The run's work (the replayed days' rows,
the depots, the methods registered at run time) goes to each worker once; a worker sets
itself up from it as a local pool's worker does (marops_cli/workers/pool.py) and runs
one job at a time, whatever its thread count, so two jobs never share a policy.
Outcomes come back as jobs finish; the caller writes and orders them, so the results do
not depend on where a job ran.
"""

from __future__ import annotations

import logging
import signal
import threading
import uuid
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from types import ModuleType
from typing import Any

from ..errors import InputError
from .threads import one_thread
from .work import Job, Outcome, Work, run_safe

INSTALL = "pip install 'marops[cluster]'"
LOCAL = "local"  # --scheduler local: a LocalCluster of --workers processes on this machine
CONNECT_TIMEOUT_S = 10


def require_distributed() -> ModuleType:
    """The ``distributed`` package, or one line saying how to install it."""
    try:
        import distributed
    except ImportError:
        raise InputError(f"--scheduler needs Dask's distributed package: {INSTALL}") from None
    return distributed


@contextmanager
def _sigint_ignored() -> Iterator[None]:
    """SIGINT ignored within (in the main thread; elsewhere nothing changes)."""
    try:
        old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


@contextmanager
def connect(scheduler: str, workers: int) -> Iterator[Any]:
    """A ``distributed.Client`` of the scheduler at ``scheduler``, or of a LocalCluster
    of ``workers`` single-threaded processes for ``local``; closed on the way out."""
    distributed = require_distributed()
    if scheduler == LOCAL:
        # Ctrl-C reaches the whole process group: this process stops the cluster and
        # keeps what finished; its workers start with SIGINT ignored (inherited), so
        # none prints a traceback.
        with _sigint_ignored():
            cluster = distributed.LocalCluster(
                n_workers=workers,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
            )
        try:
            with distributed.Client(cluster) as client:
                yield client
        finally:
            cluster.close()
        return
    try:
        client = distributed.Client(scheduler, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        why = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"--scheduler {scheduler}: no Dask scheduler answered ({why})") from None
    with client:
        yield client


_ONE_AT_A_TIME = threading.Lock()  # per cluster worker process
_SET_UP: dict[str, Any] = {}  # per cluster worker process: the work it set up last


def _cluster_job(job: Job, work: Work) -> Outcome:
    with _ONE_AT_A_TIME:
        if _SET_UP.get("work") is not work:
            problem = work.refuse()
            if problem is not None:
                return Outcome(job.index, None, problem, 2)
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
