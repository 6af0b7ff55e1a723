"""Per-day metrics of docs/method.md §8 (paper §V-B): their spec, the combined cost, and
the record of one replayed day."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..energy import EnergyModel
from ..plans.view import FREE
from .fleet import DEFAULT_TYPE, Fleet
from .reach import unservable_masks
from .replay import FlownDay

CO2_G_PER_KWH = 125.0  # UK 2024 grid average, as the paper


@dataclass(frozen=True)
class MetricSpec:
    """One day-metric column (docs/outputs.md, "Day metrics"; docs/method.md §8 defines it)."""

    name: str  # key in metrics.json, column of results.parquet
    unit: str  # as docs/outputs.md gives it
    label: str  # row of the summary tables (summary.md, the paper's Table III wording)
    fmt: str  # a mean over days in those tables
    header: str  # column of the day tables (replay-day, train)
    day_fmt: str  # one day's value in those tables
    lower_is_better: bool | None  # None: neither (counts of the input, early arrival, battery)


_M = MetricSpec
# Every value of a day's record (``day_metrics``) but the identifiers ``day``,
# ``method`` and ``hub``, the per-depot ``depot_load_kg`` and the per-type
# ``drone_types``, in the record's order, ``solver`` flattened as the result tables
# flatten it (``solver_calls``, ...).
DAY_METRICS: tuple[MetricSpec, ...] = (
    _M(
        "mean_energy_kj",
        "kJ",
        "Mean energy consumption (kJ)",
        "{:.1f}",
        "energy kJ/drone",
        "{:.1f}",
        True,
    ),
    _M("avg_delay_h", "h", "Average delivery delay (h)", "{:.2f}", "delay h", "{:.3f}", True),
    _M("delay_unfairness", "0–1", "Delay unfairness", "{:.2f}", "unfairness", "{:.3f}", True),
    _M("runtime_s", "s", "Average running time (s)", "{:.2f}", "runtime s", "{:.3f}", True),
    _M("avg_early_h", "h", "Average early arrival (h)", "{:.2f}", "early h", "{:.3f}", None),
    _M("co2_g", "g", "CO2 per day (g)", "{:.0f}", "CO2 g", "{:.1f}", True),
    _M("delivered", "count", "Delivered per day", "{:.1f}", "delivered", "{}", False),
    _M("undelivered", "count", "Undelivered per day", "{:.1f}", "undelivered", "{}", True),
    _M("requests", "count", "Requests per day", "{:.1f}", "requests", "{}", None),
    _M("orders_due", "count", "Orders due per day", "{:.1f}", "orders due", "{}", None),
    _M("outside_area", "count", "Outside the area per day", "{:.1f}", "outside area", "{}", None),
    _M("outside_hours", "count", "Outside hours per day", "{:.1f}", "outside hours", "{}", None),
    _M("unservable_heavy", "count", "Too heavy per day", "{:.1f}", "too heavy", "{}", None),
    _M("unservable_far", "count", "Too far per day", "{:.1f}", "too far", "{}", None),
    _M("battery_frac_mean", "0–1", "Battery used per flight", "{:.2f}", "battery", "{:.3f}", None),
    _M(
        "battery_frac_max",
        "0–1",
        "Most battery a flight used",
        "{:.2f}",
        "battery max",
        "{:.3f}",
        None,
    ),
    _M("energy_kj", "kJ", "Energy per day (kJ)", "{:.1f}", "energy kJ", "{:.1f}", True),
    _M("drones", "count", "Drones", "{:.0f}", "drones", "{}", None),
    _M("objective_j_mj", "MJ", "Day objective J (MJ)", "{:.2f}", "J MJ", "{:.2f}", True),
    _M("objective_g_mj", "MJ", "Day objective G (MJ)", "{:.2f}", "G MJ", "{:.2f}", False),
    _M("delivered_share", "0–1", "Delivered share", "{:.3f}", "delivered share", "{:.3f}", False),
    _M("actions_stay", "0–1", "Decisions to stay", "{:.3f}", "stay", "{:.3f}", None),
    _M("actions_move", "0–1", "Decisions to move", "{:.3f}", "move", "{:.3f}", None),
    _M("actions_free", "0–1", "Decisions to land freely", "{:.3f}", "free", "{:.3f}", None),
    _M(
        "waiting_max",
        "count",
        "Most parcels waiting at a depot",
        "{:.1f}",
        "waiting max",
        "{}",
        None,
    ),
    _M("solver_calls", "count", "Selection programs per day", "{:.1f}", "solves", "{}", None),
    _M("solver_fallbacks", "count", "Solver fallbacks per day", "{:.1f}", "fallbacks", "{}", True),
    _M("solver_solve_s", "s", "Selection solve time (s)", "{:.2f}", "solve s", "{:.3f}", True),
)
# Comparisons of methods (docs/method.md §8), from :func:`combined_cost`: ``evaluate``'s on
# the methods' means, and training's per day then averaged over days.
COMBINED_COST = _M(
    "combined_cost", "ratio", "Combined cost", "{:.2f}", "combined cost", "{:.3f}", True
)
DAILY_COMBINED_COST = _M(
    "daily_combined_cost",
    "ratio",
    "Daily combined cost",
    "{:.3f}",
    "daily combined cost",
    "{:.3f}",
    True,
)
# What the operating model holds back (docs/method.md, "Operating model"): in a day's
# record only when the day ran under a model other than the paper's, so the paper's
# records and tables stay as they were.
OPS_METRICS: tuple[MetricSpec, ...] = (
    _M("actions_idle", "0–1", "Drone-windows held back", "{:.3f}", "idle", "{:.3f}", None),
    _M(
        "battery_waits",
        "count",
        "Windows waited for a battery",
        "{:.1f}",
        "battery waits",
        "{}",
        True,
    ),
    _M("busy_windows", "count", "Windows on long flights", "{:.1f}", "busy", "{}", None),
    _M("stock_left_total", "count", "Parcels left at depots", "{:.1f}", "stock left", "{}", True),
    _M(
        "stock_left_max",
        "count",
        "Most parcels left at a depot",
        "{:.1f}",
        "stock left max",
        "{}",
        True,
    ),
    _M(
        "charged_min",
        "count",
        "Fewest charged spare batteries",
        "{:.1f}",
        "charged min",
        "{}",
        None,
    ),
)
METRICS: dict[str, MetricSpec] = {
    m.name: m for m in (*DAY_METRICS, *OPS_METRICS, COMBINED_COST, DAILY_COMBINED_COST)
}


def metric_specs(*names: str) -> tuple[MetricSpec, ...]:
    """The specs of ``names``, in that order: a table's own choice of metrics. A name
    without a spec is an error (KeyError), so no table lists a column that does not exist."""
    return tuple(METRICS[n] for n in names)


def metric_names(*names: str) -> tuple[str, ...]:
    """``names``, each checked against the spec (see :func:`metric_specs`)."""
    return tuple(m.name for m in metric_specs(*names))


def gini(values: np.ndarray) -> float:
    """Gini coefficient of non-negative values (0 = equal, → 1 = concentrated)."""
    v = np.sort(np.asarray(values, dtype=np.float64))
    n = v.size
    if n == 0 or v.sum() <= 0:
        return 0.0
    cum = np.cumsum(v)
    return float((n + 1 - 2 * (cum / cum[-1]).sum()) / n)


def combined_cost(
    energy: Sequence[float] | np.ndarray,
    delay: Sequence[float] | np.ndarray,
    scale: tuple[float, float] | None = None,
) -> np.ndarray:
    """The paper's combined cost (Table III, docs/method.md §8) of methods compared with
    each other: (energy / E + delay / D) / 2, with E and D the largest energy and delay
    among them, or ``scale`` = (E, D) when given (e.g. the largest method means, to price
    one day of a method). A metric whose largest value is 0 contributes 0.

    ``evaluate`` prices the methods' means (``combined_cost``); training evaluations the
    methods of each day, then average over days (``daily_combined_cost``).
    """
    e = np.asarray(energy, dtype=np.float64)
    d = np.asarray(delay, dtype=np.float64)
    e_top, d_top = (e.max(initial=0.0), d.max(initial=0.0)) if scale is None else scale
    return (_share(e, e_top) + _share(d, d_top)) / 2.0


def _share(values: np.ndarray, top: float) -> np.ndarray:
    return values / top if top > 0 else np.zeros_like(values)


def unservable(
    day: Any, depots_xy: np.ndarray, model: EnergyModel | Sequence[EnergyModel]
) -> tuple[int, int]:
    """How many requests no drone can ever serve: (too heavy, too far)
    (:func:`~marops_cli.sim.reach.unservable_masks`)."""
    heavy, far = unservable_masks(day, depots_xy, model)
    return int(heavy.sum()), int(far.sum())


def bound_metrics(scores: list[Any]) -> dict[str, float]:
    """With ``[plan] bound = true``: Σ over the windows of the bound on G (MJ) and the
    windows' median gap (bound − G) / |bound| (docs/method.md, "The bound"); empty
    otherwise, so the day's record is as it was."""
    bounded = [s for s in scores if s.bound_G is not None]
    if not bounded:
        return {}
    return {
        "objective_bound_mj": sum(s.bound_G for s in bounded) / 1e6,
        "gap_median": float(np.median([s.gap for s in bounded])),
    }


def ops_metrics(st: Any) -> dict[str, Any]:
    """What the operating model held back on a day (``OPS_METRICS``, and ``stock_left``
    per depot: its parcels still undelivered at the end of the day); empty under the
    paper's model."""
    ops = st.ops
    if ops is None:
        return {}
    left = np.bincount(st.area[st.delivered_w < 0], minlength=len(st.depots))
    return {
        "actions_idle": float(np.mean(ops.held_w != 0)) if ops.held_w.size else 0.0,
        "battery_waits": int(ops.battery_waits),
        "busy_windows": int(ops.busy_windows),
        "stock_left": {str(i): int(n) for i, n in enumerate(left)},
        "stock_left_total": int(left.sum()),
        "stock_left_max": int(left.max(initial=0)),
        "charged_min": ops.charged_min(),
    }


ACTION_KINDS = ("stay", "move", "free")
"""What a drone that could fly decided in a window (docs/outputs.md, "Day metrics"): stay
(action 0), move (to another candidate depot) or land freely (``FREE``, and every
decision under the ``global`` scope, whose routes land nearest their last customer)."""


def flown_actions(res: FlownDay) -> Iterator[int]:
    """The action each drone that could fly flew, window by window, drone by drone:
    ``FREE`` for a free landing and for every decision under the ``global`` scope, whose
    routes land nearest their last customer. Drones held back by the operating model
    (busy, or waiting for a battery) decide nothing and are left out."""
    held = None if res.state.ops is None else res.state.ops.held_w
    for plan in res.plans:
        for r in plan.routes:
            if held is not None and plan.t < held.shape[0] and held[plan.t, r.drone]:
                continue
            yield FREE if res.scope == "global" else int(r.action)


def action_shares(res: FlownDay) -> dict[str, float]:
    """The share of each :data:`ACTION_KINDS` among the day's decisions of drones that
    could fly (``actions_stay``, ``actions_move``, ``actions_free``; they sum to 1, or are
    all 0 without a decision). The action is the one flown (``DroneRoute.action``: a
    destination out of reach flies as stay); drones held back by the operating model
    (busy, or waiting for a battery) decide nothing and count in ``actions_idle``."""
    counts = dict.fromkeys(ACTION_KINDS, 0)
    for action in flown_actions(res):
        counts["free" if action == FREE else "stay" if action == 0 else "move"] += 1
    n = sum(counts.values())
    return {f"actions_{k}": c / n if n else 0.0 for k, c in counts.items()}


def day_metrics(
    res: FlownDay, model: EnergyModel, fleet: Fleet | None = None, hub: int = 0
) -> dict[str, Any]:
    """The ``metrics.json`` record of one replayed day (docs/outputs.md); ``fleet`` gives
    each drone's type (None: every drone is ``model``'s, the default type)."""
    st = res.state
    own = list(st.drone_models) if st.drone_models is not None else [model] * res.n_drones
    types = fleet.counts() if fleet is not None else {DEFAULT_TYPE: res.n_drones}
    day = st.day
    routes = [r for p in res.plans for r in p.routes]
    energy = np.array([r.energy_j for r in routes]) if routes else np.zeros(0)
    # Battery share of each flown route, of its own drone's battery.
    battery = np.array([own[r.drone].cfg.battery_j for r in routes]) if routes else np.ones(0)
    flown, battery = energy[energy > 0], battery[energy > 0]
    frac_mean = frac_max = 0.0
    if flown.size and np.all(battery == battery[0]):  # one battery size: as ever
        frac_mean, frac_max = flown.mean() / battery[0], flown.max() / battery[0]
    elif flown.size:
        frac_mean, frac_max = float(np.mean(flown / battery)), float(np.max(flown / battery))
    delay = st.delivery_delay_h()
    delivered = st.delivered_w >= 0
    # Early arrival: due time minus arrival time, both from service start (docs/method.md §5).
    arrival_s = st.delivered_w[delivered] * day.window_s + st.arrive_s[delivered]
    early_h = np.maximum(0.0, day.due_s[delivered] - arrival_s) / 3600.0
    # Delay unfairness over the service areas that had requests that day.
    n_areas = len(st.depots)
    area_delay = np.bincount(st.area, weights=delay, minlength=n_areas)
    has_req = np.bincount(st.area, minlength=n_areas) > 0
    load = np.zeros(n_areas)
    for r in routes:
        load[r.start] += r.payload_kg
    total_j = float(energy.sum())
    sel = [p.selection for p in res.plans]
    scores = [p.score for p in res.plans if p.score is not None]
    return {
        "day": day.day.isoformat(),
        "method": res.method,
        "hub": hub,
        "mean_energy_kj": total_j / res.n_drones / 1000.0,
        "avg_delay_h": float(delay.mean()) if delay.size else 0.0,
        "delay_unfairness": gini(area_delay[has_req]),
        "runtime_s": float(res.runtime_s),
        "avg_early_h": float(early_h.mean()) if early_h.size else 0.0,
        "co2_g": total_j / 3.6e6 * CO2_G_PER_KWH,
        "delivered": int(delivered.sum()),
        "undelivered": int((~delivered).sum()),
        "requests": int(len(day)),
        # Orders due that day that were not planned: outside the study area or hours.
        "orders_due": day.orders_due,
        "outside_area": day.outside_area,
        "outside_hours": day.outside_hours,
        # ... and planned requests no drone can serve at all (docs/outputs.md)
        **dict(
            zip(
                ("unservable_heavy", "unservable_far"),
                unservable(day, st.depots.xy, list(dict.fromkeys(own))),
                strict=True,
            )
        ),
        "depot_load_kg": {str(i): round(float(load[i]), 6) for i in range(n_areas)},
        "battery_frac_mean": float(frac_mean),
        "battery_frac_max": float(frac_max),
        "energy_kj": total_j / 1000.0,
        "drones": res.n_drones,
        "drone_types": types,
        # The day objective: the windows' J and G summed (docs/method.md), in MJ.
        "objective_j_mj": sum(s.J for s in scores) / 1e6,
        "objective_g_mj": sum(s.G for s in scores) / 1e6,
        **bound_metrics(scores),
        "delivered_share": float(delivered.mean()) if delivered.size else 1.0,
        **action_shares(res),
        "waiting_max": int(st.waiting_w.max(initial=0)),
        "solver": {
            "calls": len(sel),
            "fallbacks": int(sum(s.fallback for s in sel)),
            "solve_s": float(sum(s.solve_s for s in sel)),
        },
        **ops_metrics(st),
    }
