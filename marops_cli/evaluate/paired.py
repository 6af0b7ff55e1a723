"""Paired comparisons against a reference method (``evaluate --against``).

For each setting and method, the per-day difference method − reference of each metric
(same day, repeat and hub; a day's repeats averaged into its one difference), its mean
and a bootstrap 95 % confidence interval (resampling days with replacement, a fixed
seed, so the interval is reproducible), and how many days the method was better. A
comparison backed by fewer than :data:`MIN_DAYS` calendar days (a city's hubs on one
day are one day) is flagged and gets no verdict (``too few days (n=2)``, not ``better``
or ``worse``). The combined cost
alone can be won by delivering less, so the day objective J (which charges every
request left waiting) and the delivered share come first (docs/method.md §8).
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import numpy as np
import pyarrow as pa

from ..errors import InputError
from ..sim.metrics import metric_specs

# metric -> True when lower is better (from the spec)
PAIRED_METRICS: dict[str, bool] = {
    m.name: m.lower_is_better is True
    for m in metric_specs(
        "objective_j_mj", "delivered_share", "avg_delay_h", "mean_energy_kj", "combined_cost"
    )
}
MIN_DAYS = 10
N_BOOT = 2000
SEED = 20221  # fixed: the same rows give the same interval everywhere


def backing_days(table: pa.Table) -> int | None:
    """The fewest calendar days behind any row of ``table`` (paired.csv's or the
    summary's ``calendar_days``; a table written before it had one, its ``days``);
    None when it has no rows. A city's hubs on one day are one day here: the day's
    weather and demand reach them all, so twelve hubs over two days are two days."""
    column = "calendar_days" if "calendar_days" in table.column_names else "days"
    days = table.column(column).to_pylist() if table.num_rows else []
    return min(int(d) for d in days) if days else None


def few_days_warning(table: pa.Table) -> str | None:
    """The warning a comparison over fewer than :data:`MIN_DAYS` calendar days gets:
    ``table`` is the paired comparison (its verdicts read ``too few days``) or, without
    one, the summary (its means side by side). None when it has enough days, or no rows."""
    n_days = backing_days(table)
    if n_days is None or n_days >= MIN_DAYS:
        return None
    backs = "day backs" if n_days == 1 else "days back"
    hub_days = (
        min(int(d) for d in table.column("days").to_pylist())
        if "days" in table.column_names
        else n_days
    )
    if hub_days > n_days:  # a city's: its hub-days are the paired differences
        backs = f"{'day' if n_days == 1 else 'days'} ({hub_days} hub-days) back"
    if "against" in table.column_names:
        return (
            f"only {n_days} {backs} the paired comparison (fewer than {MIN_DAYS}): "
            f"the intervals are wide and no verdict is established (each reads "
            f"'{too_few(n_days)}')"
        )
    return (
        f"only {n_days} {backs} the comparison (fewer than {MIN_DAYS}): a difference "
        "between the methods' means is not established"
    )


def comparison_warning(summary: pa.Table, paired: pa.Table | None) -> str | None:
    """An evaluation's one warning of too few days: its paired comparison's where it has
    one, else its summary's (:func:`few_days_warning`)."""
    return few_days_warning(paired if paired is not None and paired.num_rows else summary)


def too_few(n_days: int) -> str:
    """What a comparison over fewer than :data:`MIN_DAYS` days says instead of a verdict."""
    return f"too few days (n={n_days})"


def bootstrap_ci(diff: np.ndarray, n_boot: int = N_BOOT, seed: int = SEED) -> tuple[float, float]:
    """95 % percentile interval of the mean of ``diff`` over days resampled with replacement."""
    d = np.asarray(diff, dtype=np.float64)
    if d.size == 0:
        return float("nan"), float("nan")
    if d.size == 1:
        return float(d[0]), float(d[0])
    rng = np.random.default_rng(seed)
    means = d[rng.integers(0, d.size, (n_boot, d.size))].mean(axis=1)
    lo, hi = np.quantile(means, [0.025, 0.975])
    return float(lo), float(hi)


def paired_table(results: pa.Table, against: str) -> pa.Table:
    """One row per setting × method × metric: days, mean difference, CI, days better."""
    rows = results.to_pylist()
    methods = list(dict.fromkeys(r["method"] for r in rows))
    if against not in methods:
        raise InputError(
            f"--against {against!r} is not among the methods compared ({', '.join(methods)})"
        )
    # Pairs are the same day, repeat and hub (a city's hubs are days of their own).
    by: dict[tuple[int, str], dict[tuple[int, str, int], dict[str, Any]]] = defaultdict(dict)
    for r in rows:
        by[(r["setting"], r["method"])][(r.get("hub", 0), r["day"], r["repeat"])] = r
    out: dict[str, list[Any]] = defaultdict(list)
    for (setting, method), days in by.items():
        if method == against:
            continue
        ref = by[(setting, against)]
        keys = sorted(k for k in days if k in ref)
        for metric, lower in PAIRED_METRICS.items():
            # One difference per day (a city's hub-day): the repeats of a day are one
            # day's draws, not days of their own, so they are averaged before the
            # bootstrap resamples days.
            per_day: dict[tuple[int, str], list[float]] = defaultdict(list)
            for k in keys:
                a, b = days[k].get(metric), ref[k].get(metric)
                if a is not None and b is not None:
                    per_day[k[:2]].append(a - b)
            diff = np.array([np.mean(v) for v in per_day.values()], dtype=np.float64)
            calendar = len({day for _, day in per_day})
            lo, hi = bootstrap_ci(diff)
            better = int(((diff < 0) if lower else (diff > 0)).sum())
            out["setting"].append(setting)
            out["method"].append(method)
            out["against"].append(against)
            out["metric"].append(metric)
            out["days"].append(int(diff.size))
            out["calendar_days"].append(calendar)
            out["mean_diff"].append(float(diff.mean()) if diff.size else float("nan"))
            out["ci_low"].append(lo)
            out["ci_high"].append(hi)
            out["days_better"].append(better)
            out["lower_is_better"].append(lower)
            out["few_days"].append(calendar < MIN_DAYS)
    return pa.table(dict(out))


def verdict(row: dict[str, Any]) -> str:
    """``better`` / ``worse`` when the CI excludes zero, else ``no difference``; over
    fewer than :data:`MIN_DAYS` calendar days none of these but ``too few days (n=2)``,
    whatever the interval (a verdict from a few days is not established, however many
    hubs fly them); ``n/a`` without one."""
    lo, hi = row["ci_low"], row["ci_high"]
    if not (np.isfinite(lo) and np.isfinite(hi)) or int(row["days"]) < 1:
        return "n/a"
    calendar = int(row.get("calendar_days", row["days"]))  # none in an older paired.csv
    if calendar < MIN_DAYS:
        return too_few(calendar)
    if lo > 0 or hi < 0:
        good = (hi < 0) if row["lower_is_better"] else (lo > 0)
        return "better" if good else "worse"
    return "no difference"
