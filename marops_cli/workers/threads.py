"""One OpenMP/BLAS/torch thread per process: for every worker, whose siblings already
fill the cores, and for training's own arithmetic, which must not depend on the thread
count (docs/decisions.md, "Workers")."""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager


def portable_blas() -> None:
    """Pin the code path of torch's BLAS (Intel MKL) to the one every x86 processor runs
    alike (``MKL_CBWR=COMPATIBLE``), so a trained actor's weights are the same bytes on
    any machine: by default MKL picks its kernels by processor (AVX2, AVX-512), and each
    rounds sums in its own order (docs/decisions.md, "Same results"). MKL reads it at its
    first call, so the command line does it as it starts, before any arithmetic, and its
    workers inherit it; a value the user set is kept. Once torch is loaded it is left
    alone: set in a process whose MKL may have computed already, it would reach only the
    workers, and a run on one worker and one on two would differ. (``import marops_cli``
    does the same, so the Python API pins it too when marops comes before torch.)"""
    if "torch" not in sys.modules:
        os.environ.setdefault("MKL_CBWR", "COMPATIBLE")


def one_thread(deterministic: bool = False) -> Callable[[], None]:
    """Limit this process to one OpenMP/BLAS/torch thread, torch's deterministic
    algorithms too with ``deterministic``; returns what puts the previous settings back.

    A worker keeps the limit for life; :func:`single_threaded` restores it.
    """
    from threadpoolctl import threadpool_limits

    torch = sys.modules.get("torch")
    threads = strict = None
    if torch is not None:  # read before the limits below, which torch's OpenMP shares
        threads, strict = torch.get_num_threads(), torch.are_deterministic_algorithms_enabled()
    limiter = threadpool_limits(limits=1)  # the libraries loaded so far (numpy's BLAS)
    omp = os.environ.get("OMP_NUM_THREADS")
    os.environ["OMP_NUM_THREADS"] = "1"  # and those loaded later (torch reads it)
    if torch is not None:
        torch.set_num_threads(1)
        if deterministic:
            torch.use_deterministic_algorithms(True)

    def restore() -> None:
        limiter.restore_original_limits()
        if omp is None:
            os.environ.pop("OMP_NUM_THREADS", None)
        else:
            os.environ["OMP_NUM_THREADS"] = omp
        if torch is not None:
            torch.set_num_threads(threads)
            torch.use_deterministic_algorithms(strict)

    return restore


@contextmanager
def single_threaded(deterministic: bool = False) -> Iterator[None]:
    """:func:`one_thread` within, the previous settings back on the way out."""
    restore = one_thread(deterministic)
    try:
        yield
    finally:
        restore()
