"""Held-out comparison of methods: day metrics -> mean ± std, combined cost (docs/method.md §8).

Combined cost is computed per day over the methods compared that day: the mean
of energy / max energy and delay / max delay (the paper's Table III), then
averaged over days (mean ± std across days).
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import numpy as np

TABLE_KEYS = (
    "mean_energy_kj",
    "avg_delay_h",
    "combined_cost",
    "delay_unfairness",
    "avg_early_h",
    "delivered",
    "delivered_share",
    "objective_j_mj",
    "objective_g_mj",
)


def combined_costs(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Add ``combined_cost`` to every row: per day, over the methods present that day."""
    by_day: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        by_day[r["day"]].append(r)
    out = []
    for day_rows in by_day.values():
        e_max = max(r["mean_energy_kj"] for r in day_rows) or 1.0
        d_max = max(r["avg_delay_h"] for r in day_rows) or 1.0
        for r in day_rows:
            cc = 0.5 * (r["mean_energy_kj"] / e_max + r["avg_delay_h"] / d_max)
            out.append({**r, "combined_cost": cc})
    return out


def method_table(rows: list[dict[str, Any]]) -> dict[str, dict[str, tuple[float, float]]]:
    """``{method: {metric: (mean, std)}}`` over days, combined cost included."""
    rows = combined_costs(rows)
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
