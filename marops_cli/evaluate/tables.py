"""The results table (one row per day × method × setting × repeat) and its summary.

Combined cost (docs/method.md §8, paper Table III; :func:`~marops_cli.sim.metrics.combined_cost`)
is computed over the methods of one setting *on the means*: with Ē_m and D̄_m a method's
mean energy and delay over its days and repeats,

    combined_cost_m = ( Ē_m / max_k Ē_k  +  D̄_m / max_k D̄_k ) / 2.

Each row carries its own share, ( E / max_k Ē_k + D / max_k D̄_k ) / 2, so that the
mean of a method's rows is exactly its combined cost and the spread of the rows
gives its standard deviation.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pyarrow as pa

from ..methods import method as method_spec
from ..sim.metrics import METRICS, combined_cost, metric_names
from .runner import Prepared
from .settings import Job, Setting

SETTING_COLUMNS = ("setting", "alpha", "drones", "coverage", "depots_n", "n_actions")
KEY_COLUMNS = (*SETTING_COLUMNS, "segmentation", "hub", "method", "repeat", "seed", "day")
# Summarised metrics, in the order of the summary's columns.
SUMMARY_METRICS = metric_names(
    "mean_energy_kj",
    "avg_delay_h",
    "combined_cost",
    "delay_unfairness",
    "runtime_s",
    "avg_early_h",
    "co2_g",
    "delivered",
    "undelivered",
    "requests",
    "delivered_share",
    "objective_j_mj",
    "objective_g_mj",
    "battery_frac_mean",
    "battery_frac_max",
    "solver_fallbacks",
    "actions_stay",
    "actions_move",
    "actions_free",
    "waiting_max",
    # under an operating model only (the summary leaves out a column no row has)
    "actions_idle",
    "battery_waits",
)
DEPOT_LOAD_PREFIX = "depot_load_kg_"


def flatten(metrics: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested metric records as flat columns: ``solver.calls`` -> ``solver_calls``."""
    flat: dict[str, Any] = {}
    for key, value in metrics.items():
        if isinstance(value, dict):
            flat.update(flatten(value, f"{prefix}{key}_"))
        else:
            flat[f"{prefix}{key}"] = value
    return flat


def key_columns(prep: Prepared, job: Job) -> dict[str, Any]:
    """A job's :data:`KEY_COLUMNS`: its setting, segmentation, hub, method, repeat, seed,
    day."""
    s = prep.settings[job.setting]
    row: dict[str, Any] = {"setting": job.setting, **s.columns()}
    row["drones"] = prep.drones(job)  # a hub's own fleet size, with --hubs
    row["n_actions"] = prep.cfg.segment.n_actions
    row["segmentation"] = method_spec(job.method).segmentation
    row.update(hub=job.hub, method=job.method, repeat=job.repeat, seed=job.seed, day=job.day)
    return row


def job_row(prep: Prepared, job: Job, metrics: dict[str, Any]) -> dict[str, Any]:
    """A job's row of ``results.parquet`` (less ``combined_cost``, which spans jobs):
    its key columns, then every day metric flattened."""
    row = key_columns(prep, job)
    rest = {k: v for k, v in metrics.items() if k not in ("day", "hub", "method", "drones")}
    row.update(flatten(rest))
    return row


def results_table(prep: Prepared, metrics: Sequence[dict[str, Any]]) -> pa.Table:
    """One row per job: setting columns, repeat, seed, then every day metric flattened."""
    return rows_table([job_row(prep, job, m) for job, m in zip(prep.jobs, metrics, strict=True)])


def rows_table(rows: Sequence[dict[str, Any]]) -> pa.Table:
    """``results.parquet`` from the jobs' rows (:func:`job_row`), in job order."""
    columns = _column_order(rows)
    data = {c: [r.get(c) for r in rows] for c in columns}
    table = pa.table({c: _array(c, v) for c, v in data.items()})
    return _with_combined_cost(table)


def _column_order(rows: Sequence[dict[str, Any]]) -> list[str]:
    seen = dict.fromkeys(c for r in rows for c in r)
    loads = sorted(
        (c for c in seen if c.startswith(DEPOT_LOAD_PREFIX)),
        key=lambda c: int(c.removeprefix(DEPOT_LOAD_PREFIX)),
    )
    # Depot loads last and by depot id, so a sweep over the number of depots lines up.
    return [c for c in seen if not c.startswith(DEPOT_LOAD_PREFIX)] + loads


def row_table(row: dict[str, Any]) -> pa.Table:
    """One row as a table with the column types ``results.parquet`` gives it."""
    return pa.table({c: _array(c, [v]) for c, v in row.items()})


def _array(name: str, values: list[Any]) -> pa.Array:
    if name.startswith(DEPOT_LOAD_PREFIX) or any(isinstance(v, float) for v in values):
        return pa.array([None if v is None else float(v) for v in values], type=pa.float64())
    if name in METRICS and all(v is None for v in values):
        # A metric no row has a value of (charged_min under unlimited swaps) keeps its
        # type, a count's int64 or float64, not Arrow's type of nulls alone.
        kind = pa.int64() if METRICS[name].unit == "count" else pa.float64()
        return pa.array(values, type=kind)
    return pa.array(values)


def _with_combined_cost(table: pa.Table) -> pa.Table:
    setting = table.column("setting").to_numpy()
    method = np.asarray(table.column("method").to_pylist(), dtype=object)
    energy = table.column("mean_energy_kj").to_numpy().astype(np.float64)
    delay = table.column("avg_delay_h").to_numpy().astype(np.float64)
    cost = np.zeros(table.num_rows)
    for s in np.unique(setting):
        in_s = setting == s
        names = list(dict.fromkeys(method[in_s]))
        e_top = max(float(energy[in_s & (method == m)].mean()) for m in names)
        d_top = max(float(delay[in_s & (method == m)].mean()) for m in names)
        cost[in_s] = combined_cost(energy[in_s], delay[in_s], scale=(e_top, d_top))
    at = table.schema.get_field_index("avg_delay_h") + 1
    return table.add_column(at, "combined_cost", pa.array(cost, type=pa.float64()))


def mean_std(values: np.ndarray) -> tuple[float, float]:
    """Mean and sample standard deviation (ddof 1; NaN, shown as n/a, for a single value:
    one day has no spread to report)."""
    v = np.asarray(values, dtype=np.float64)
    return float(v.mean()), float(v.std(ddof=1)) if v.size > 1 else float("nan")


def summarize(results: pa.Table, settings: Sequence[Setting] | None = None) -> pa.Table:
    """Mean and std of each metric per setting and method (methods in first-seen order).
    A setting's columns are its own (``settings``, by index): over hubs each row's
    ``drones`` is its hub's share of the setting's fleet, the summary's the setting's.
    ``n`` counts the results a row summarises (days × repeats, × hubs),
    ``calendar_days`` the days they span (a city's hubs on one day are one day) and
    ``few_days`` says these are fewer than :data:`~marops_cli.evaluate.paired.MIN_DAYS`:
    too few to tell the methods apart."""
    from .paired import MIN_DAYS

    cols = {c: results.column(c).to_pylist() for c in (*SETTING_COLUMNS, "segmentation", "method")}
    setting = np.asarray(cols["setting"])
    method = np.asarray(cols["method"], dtype=object)
    day_of = results.column("day").to_pylist()
    metrics = [m for m in SUMMARY_METRICS if m in results.column_names]
    values = {m: results.column(m).to_numpy().astype(np.float64) for m in metrics}
    out: dict[str, list[Any]] = {c: [] for c in (*SETTING_COLUMNS, "segmentation", "method")}
    out["n"], out["calendar_days"], out["few_days"] = [], [], []
    for m in metrics:
        out[f"{m}_mean"], out[f"{m}_std"] = [], []
    for s in sorted(set(setting.tolist())):
        for name in dict.fromkeys(method[setting == s]):
            rows = np.flatnonzero((setting == s) & (method == name))
            own = settings[int(s)].columns() if settings is not None else {}
            for c in (*SETTING_COLUMNS, "segmentation", "method"):
                out[c].append(own.get(c, cols[c][rows[0]]))
            out["n"].append(int(rows.size))
            n_days = len({day_of[i] for i in rows.tolist()})
            out["calendar_days"].append(n_days)
            out["few_days"].append(n_days < MIN_DAYS)
            for m in metrics:
                mean, std = mean_std(values[m][rows])
                out[f"{m}_mean"].append(mean)
                out[f"{m}_std"].append(std)
    return pa.table(out)


def depot_loads(results: pa.Table, where: np.ndarray) -> np.ndarray:
    """Mean parcel weight (kg) picked up at each depot over the rows in ``where``."""
    cols = [c for c in results.column_names if c.startswith(DEPOT_LOAD_PREFIX)]
    loads = np.column_stack(
        [results.column(c).to_numpy(zero_copy_only=False).astype(np.float64) for c in cols]
    )
    sub = loads[where]
    keep = ~np.all(np.isnan(sub), axis=0)  # depots that exist in this setting
    return np.nanmean(sub[:, keep], axis=0) if sub.size else np.zeros(0)


# How a setting's value reads in a label (``α=0.3``, ``8 drones``).
_LABELS = {
    "alpha": "α={:g}",
    "drones": "{} drones",
    "coverage": "coverage {:g}",
    "depots_n": "{} areas",
}


def setting_label(summary: pa.Table, setting: int) -> str:
    """A setting by the values that tell it apart from the others of the summary:
    ``α=0.3``, ``α=0.3, 16 drones``; the trade-off weight when nothing was swept."""
    rows = summary.to_pylist()
    varied = [f for f in _LABELS if len({r[f] for r in rows}) > 1] or ["alpha"]
    row = next(r for r in rows if r["setting"] == setting)
    return ", ".join(_LABELS[f].format(row[f]) for f in varied)
