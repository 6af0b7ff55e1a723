"""One call from a prepared evaluation to its results and summary tables."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import pyarrow as pa

from .runner import OnResult, Prepared, run
from .tables import job_row, rows_table, summarize

if TYPE_CHECKING:
    from .dataset import JobStore


@dataclass
class Evaluation:
    """What an evaluation produced: the per-day rows and their summary."""

    prep: Prepared
    results: pa.Table
    summary: pa.Table


def evaluate_jobs(
    prep: Prepared,
    workers: int = 2,
    on_result: OnResult | None = None,
    store: JobStore | None = None,
    scheduler: str | None = None,
) -> Evaluation:
    """Run every job of ``prep`` on ``workers`` processes (or the Dask cluster at
    ``scheduler``) and summarise the rows. With a ``store`` (the jobs dataset), the jobs
    it holds are not run again, each finished job is written to it at once, and the rows
    are read back from it in job order."""
    ran = run(prep, workers, on_result, store, scheduler)
    if store is None:
        rows = [job_row(prep, job, ran[job.index]) for job in prep.jobs]
    else:
        rows = store.rows()
    results = rows_table(rows)
    return Evaluation(prep, results, summarize(results, prep.settings))
