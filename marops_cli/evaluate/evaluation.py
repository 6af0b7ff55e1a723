"""One call from a prepared evaluation to its results and summary tables."""

from __future__ import annotations

from dataclasses import dataclass

import pyarrow as pa

from .runner import Journal, OnResult, Prepared, run
from .tables import results_table, summarize


@dataclass
class Evaluation:
    """What an evaluation produced: the per-day rows and their summary."""

    prep: Prepared
    results: pa.Table
    summary: pa.Table


def evaluate(
    prep: Prepared,
    workers: int = 2,
    on_result: OnResult | None = None,
    journal: Journal | None = None,
) -> Evaluation:
    """Run every job of ``prep`` on ``workers`` processes and summarise the rows."""
    results = results_table(prep, run(prep, workers, on_result, journal))
    return Evaluation(prep, results, summarize(results))
