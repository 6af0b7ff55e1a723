"""An evaluation's jobs on a Dask cluster: ``marops evaluate --scheduler ADDRESS|local``
(README.md "Sweeps on a cluster").

``distributed`` is an optional extra (``pip install 'marops[cluster]'``), imported only
here and only when a scheduler is asked for. The run's context (the replayed days' rows,
the depots, the methods registered at run time) goes to each worker once; a worker sets
itself up from it as a local pool's worker does (one OpenMP/BLAS/torch thread, methods
registered: marops_cli/evaluate/runner.py) and runs one job at a time, whatever its
thread count, so two jobs never share a policy. Outcomes come back as jobs finish; the
caller writes and orders them, so the rows do not depend on where a job ran.
"""

from __future__ import annotations

import logging
import signal
import socket
import threading
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType
from typing import Any

from ..data.reader import sha256_file
from ..errors import InputError
from . import runner
from .runner import Outcome, Prepared
from .settings import Job

INSTALL = "pip install 'marops[cluster]'"
LOCAL = "local"  # --scheduler local: a LocalCluster of --workers processes on this machine
CONNECT_TIMEOUT_S = 10

_ONE_AT_A_TIME = threading.Lock()  # per worker process


def require_distributed() -> ModuleType:
    """The ``distributed`` package, or one line saying how to install it."""
    try:
        import distributed
    except ImportError:
        raise InputError(f"--scheduler needs Dask's distributed package: {INSTALL}") from None
    return distributed


_CHECKED: dict[str, Any] = {}  # per worker process: the context whose actors were checked


def _job(job: Job, prep: Prepared, actors: dict[str, str]) -> Outcome:
    with _ONE_AT_A_TIME:
        if _CHECKED.get("prep") is not prep:
            problem = _other_actor(prep, actors)
            if problem is not None:
                return job.index, None, problem, 2
            _CHECKED["prep"] = prep
        return runner.run_in_context(prep, job)


def _other_actor(prep: Prepared, actors: dict[str, str]) -> str | None:
    """Why this worker would not run the trained actors ``evaluate`` resolved (method ->
    SHA-256), or None: a machine with another marops version or another actor file at
    that path would give other rows under the same run identity."""
    for method, sha in actors.items():
        found = runner.method_policy(method, prep.actors, 0).identity
        if not isinstance(found, Path) or sha256_file(found) != sha:
            return (
                f"a worker on {socket.gethostname()} runs another trained actor for {method} "
                f"({found}); install the same marops and actor files on every machine"
            )
    return None


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


@contextmanager
def cluster_outcomes(
    prep: Prepared, todo: list[Job], scheduler: str, workers: int
) -> Iterator[Iterator[Outcome]]:
    """Outcomes of ``todo`` run on the cluster, as they finish (submitted in job order)."""
    distributed = require_distributed()
    with connect(scheduler, workers) as client:
        context = client.scatter(runner.worker_context(prep), broadcast=True, hash=False)
        actors = {m: sha256_file(p) for m, p in prep.actor_files.items()}
        name = f"marops-evaluate-{uuid.uuid4().hex[:8]}"
        futures = [
            client.submit(_job, job, context, actors, key=(name, job.index), pure=False)
            for job in todo
        ]
        try:
            yield (outcome for _, outcome in distributed.as_completed(futures, with_results=True))
        finally:
            client.cancel(futures)
