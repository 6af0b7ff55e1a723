"""Held-out comparison of methods in training: day metrics -> mean ± std over days, with
the daily combined cost (docs/method.md §8).

The daily combined cost of a method is its combined cost on one day, over the methods
compared that day (:func:`~marops_cli.sim.metrics.combined_cost`: each day normalised by
that day's largest energy and delay), then averaged over days (mean ± std across days).
It is not ``evaluate``'s ``combined_cost``, which normalises once, by the largest means.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import numpy as np

from ..sim.metrics import combined_cost, metric_names

TABLE_KEYS = metric_names(
    "mean_energy_kj",
    "avg_delay_h",
    "daily_combined_cost",
    "delay_unfairness",
    "avg_early_h",
    "delivered",
    "delivered_share",
    "objective_j_mj",
    "objective_g_mj",
)


def daily_combined_costs(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Add ``daily_combined_cost`` to every row: its day's combined cost, over the methods
    present that day."""
    by_day: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        by_day[r["day"]].append(r)
    out = []
    for day_rows in by_day.values():
        cost = combined_cost(
            [r["mean_energy_kj"] for r in day_rows], [r["avg_delay_h"] for r in day_rows]
        )
        out += [{**r, "daily_combined_cost": float(c)} for r, c in zip(day_rows, cost, strict=True)]
    return out


def method_table(rows: list[dict[str, Any]]) -> dict[str, dict[str, tuple[float, float]]]:
    """``{method: {metric: (mean, std)}}`` over days, the daily combined cost included."""
    rows = daily_combined_costs(rows)
    by_method: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        by_method[r["method"]].append(r)
    table: dict[str, dict[str, tuple[float, float]]] = {}
    for m, rs in by_method.items():
        table[m] = {}
        for k in TABLE_KEYS:
            v = np.array([float(r[k]) for r in rs if k in r])
            if v.size:
                table[m][k] = (float(v.mean()), float(v.std()))
    return table


def summarise(rows: list[dict[str, Any]], baselines: list[dict[str, Any]]) -> dict[str, Any]:
    """A held-out evaluation of the actor (``rows``) beside the baselines, for logs and sidecars."""
    table = method_table(rows + baselines)
    means = {m: {k: round(v[0], 4) for k, v in t.items()} for m, t in table.items()}
    return {"days": [r["day"] for r in rows], "methods": means}
