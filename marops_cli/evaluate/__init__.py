"""Method comparison, sweeps and plots (paper §V, docs/method.md §7–9).

``prepare`` reads the data once and lists the jobs (day × method × setting ×
repeat), ``evaluate_jobs`` runs them over worker processes, ``write_outputs`` writes
``results.parquet``, ``summary.csv``, ``summary.md`` and the figures together.
"""

from ..sim.metrics import combined_cost
from .evaluation import Evaluation, evaluate_jobs
from .paper import PAPER_NAMES, TABLE3, paper_table
from .report import markdown_table, summary_markdown, sweep_table, table3, write_outputs
from .runner import Prepared, check_methods, prepare, run
from .settings import (
    SWEEP_FLAGS,
    Job,
    Setting,
    expand_settings,
    parse_values,
    plan_jobs,
    split_days,
    swept_flags,
)
from .tables import results_table, summarize

__all__ = [
    "PAPER_NAMES",
    "SWEEP_FLAGS",
    "TABLE3",
    "Evaluation",
    "Job",
    "Prepared",
    "Setting",
    "check_methods",
    "combined_cost",
    "evaluate_jobs",
    "expand_settings",
    "markdown_table",
    "paper_table",
    "parse_values",
    "plan_jobs",
    "prepare",
    "results_table",
    "run",
    "split_days",
    "summarize",
    "summary_markdown",
    "sweep_table",
    "swept_flags",
    "table3",
    "write_outputs",
]
