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

import gc
import logging
import threading
import uuid
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from types import ModuleType
from typing import Any

from ..errors import InputError, option
from .pool import local_workers, sigint_ignored
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
        raise InputError(
            f"{option('scheduler')} needs Dask's distributed package: {INSTALL}"
        ) from None
    return distributed


def check_scheduler(scheduler: str) -> None:
    """Before any work: ``--scheduler`` needs distributed, and an address Dask can connect
    to (``local``, or ``SCHEME://HOST:PORT`` of a scheme it knows), else one line."""
    require_distributed()
    if scheduler != LOCAL:
        _address(scheduler)


def _address(scheduler: str) -> tuple[str, int] | None:
    """The host and port of a ``tcp://`` address (None for another scheme Dask knows), or
    one line saying ``scheduler`` is no address."""
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import get_backend

    try:
        scheme, location = parse_address(scheduler, strict=False)
        get_backend(scheme)  # one Dask knows
        if scheme != "tcp":
            return None
        host, port = parse_host_port(location)
    except (ValueError, TypeError) as exc:
        raise InputError(
            f"{option('scheduler')} {scheduler}: not a scheduler address ({_why(exc)})"
        ) from None
    return host, port


def owner_only() -> Any:
    """The security of a local cluster that only this process can use: TLS with a
    certificate authority and a key made for this run, kept in memory and handed to the
    cluster's processes as they start (never written to a file), and required of every
    peer, so a process without them (another user's) is refused before any message."""
    from distributed.security import Security

    try:
        return Security.temporary()
    except ImportError:  # Dask makes the certificate with the cryptography package
        raise InputError(
            f"{option('scheduler')} local secures its cluster with TLS, which needs the "
            f"cryptography package: {INSTALL}"
        ) from None


# What each process of a cluster serves over plain HTTP besides its comm (metrics, health,
# a JSON view of the scheduler): nothing. A local cluster has no dashboard either.
_NO_HTTP: dict[str, list[str]] = {
    "distributed.scheduler.http.routes": [],
    "distributed.worker.http.routes": [],
}


def _stop_http(dask_scheduler: Any = None, dask_worker: Any = None) -> None:
    """Close the HTTP server Dask opens in each of its processes even without a
    dashboard (the scheduler's on port 8787): run on the scheduler and each worker."""
    server = getattr(dask_scheduler or dask_worker, "http_server", None)
    if server is not None:
        server.stop()


@contextmanager
def connect(scheduler: str, workers: int) -> Iterator[Any]:
    """A ``distributed.Client`` of the scheduler at ``scheduler``, or of a LocalCluster
    of ``workers`` single-threaded processes for ``local`` (at most
    :func:`~.pool.local_workers`), usable by this process alone
    (:func:`owner_only`, no HTTP server); closed on the way out."""
    distributed = require_distributed()
    if scheduler == LOCAL:
        import dask

        security = owner_only()
        # Ctrl-C reaches the whole process group: this process stops the cluster and
        # keeps what finished; its workers start with SIGINT ignored (inherited), so
        # none prints a traceback.
        with sigint_ignored(), dask.config.set(_NO_HTTP):
            cluster = distributed.LocalCluster(
                n_workers=local_workers(workers),
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                security=security,
                protocol="tls://",
                dashboard_address=None,
                # A worker's errors reach this process with its job's result; what the
                # workers log besides (a heartbeat lost while the cluster closes) is
                # not the user's business.
                silence_logs=logging.CRITICAL,
            )
        # The scheduler's tasks run in this process: one a stop cuts short (a scatter
        # whose worker left) is logged by asyncio as a traceback, never retrieved.
        quiet = logging.getLogger("asyncio")
        level = quiet.level
        quiet.setLevel(logging.CRITICAL)
        try:
            with distributed.Client(cluster, security=security) as client:
                client.run_on_scheduler(_stop_http)
                client.run(_stop_http)
                yield client
        finally:
            try:
                cluster.close()
                gc.collect()  # the tasks it dropped, logged (not) now
            finally:
                quiet.setLevel(level)
        return
    _probe(scheduler)
    try:
        client = distributed.Client(scheduler, timeout=CONNECT_TIMEOUT_S)
    except Exception as exc:  # whatever the handshake met, one line (MemoryError included)
        raise InputError(
            f"{option('scheduler')} {scheduler}: no Dask scheduler answered ({_why(exc)})"
        ) from None
    with client:
        yield client


def _why(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


_MAX_HANDSHAKE_BYTES = 1 << 20  # a Dask handshake is a few dozen bytes


def _probe(scheduler: str) -> None:
    """Refuse, within ``CONNECT_TIMEOUT_S``, an address where no Dask scheduler listens.

    A Dask scheduler speaks first: on a new TCP connection it sends its handshake, a
    message whose first 8 bytes are its length (little-endian). A web server (or anything
    else) waits for a request, sends a banner, or answers the client's handshake with
    text that Dask would read as a length of exabytes; the probe sends nothing and judges
    the first bytes, so nothing is allocated and nothing waits past the timeout. Only
    ``tcp://`` addresses are probed (TLS and others go straight to Dask).
    """
    import socket

    address = _address(scheduler)
    if address is None:
        return
    host, port = address
    first = b""
    try:
        with socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S) as sock:
            sock.settimeout(CONNECT_TIMEOUT_S)
            while len(first) < 8:
                chunk = sock.recv(8 - len(first))
                if not chunk:
                    break
                first += chunk
    except TimeoutError:
        pass  # judged below: it said too little
    except OSError as exc:
        raise InputError(
            f"{option('scheduler')} {scheduler}: no Dask scheduler answered ({_why(exc)})"
        ) from None
    if len(first) < 8:
        heard = f"it sent {first!r}" if first else "it sent nothing"
        raise InputError(
            f"{option('scheduler')} {scheduler}: not a Dask scheduler ({heard} within "
            f"{CONNECT_TIMEOUT_S} s of connecting; a Dask scheduler speaks first)"
        )
    if not 0 < int.from_bytes(first, "little") < _MAX_HANDSHAKE_BYTES:
        raise InputError(
            f"{option('scheduler')} {scheduler}: not a Dask scheduler (it sent {first!r}, "
            "not a Dask handshake)"
        )


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
