"""Jobs over worker processes or a Dask cluster, for ``evaluate``, multi-day
``replay-day`` and training's rollouts alike (docs/decisions.md, "Workers").

A :class:`Work` is everything its jobs need (the replayed days' rows, the depots, the
method; training's scenarios), sent to each worker once; a worker sets itself up from
it (one OpenMP/BLAS/torch thread, :meth:`Work.setup`) before its first job and reuses
that set-up for every later job. Each job is a typed record that carries its ``index``;
outcomes come back as jobs finish, and the caller puts them in order, so no result
depends on where a job ran.

Below every stage of the planner: it imports nothing of marops but its errors, and a
work names the modules its workers preload.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager

from .pool import LocalPool, warm_up
from .threads import one_thread, single_threaded
from .work import Job, Outcome, Work

__all__ = [
    "Job",
    "LocalPool",
    "Outcome",
    "Work",
    "one_thread",
    "outcomes",
    "single_threaded",
    "warm_up",
]


@contextmanager
def outcomes(
    work: Work, todo: Sequence[Job], workers: int, scheduler: str | None, name: str
) -> Iterator[Iterator[Outcome]]:
    """Outcomes of ``todo`` as they finish: on the Dask cluster at ``scheduler``, else on
    ``workers`` local processes (this one when 1, or for a single job)."""
    if not todo:
        yield iter(())
    elif scheduler is not None:
        from .cluster import cluster_outcomes

        with cluster_outcomes(work, todo, scheduler, workers, name) as out:
            yield out
    else:
        with LocalPool(work, min(workers, len(todo))) as pool:
            yield pool.outcomes(todo)
