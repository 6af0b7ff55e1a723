"""Per-day metrics of docs/method.md §8 (paper §V-B)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..energy import EnergyModel
from .replay import DayResult

CO2_G_PER_KWH = 125.0  # UK 2024 grid average, as the paper


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


def unservable(day: Any, depots_xy: np.ndarray, model: EnergyModel) -> tuple[int, int]:
    """Requests no drone can ever serve: (heavier than the payload limit, too far: even
    alone, from the nearest depot and back to the nearest depot, over the usable battery)."""
    from ..plans.pool import nearest_depot_m

    heavy = day.weight_kg > model.max_payload_kg + 1e-9
    d = nearest_depot_m(np.column_stack([day.x_m, day.y_m]), depots_xy)
    w = np.minimum(day.weight_kg, model.max_payload_kg)
    alone = d * np.interp(w, model.grid_kg, model.table_j_per_m) + d * model.energy_per_m(0.0)
    far = ~heavy & (alone > model.usable_j)
    return int(heavy.sum()), int(far.sum())


def day_metrics(res: DayResult, model: EnergyModel) -> dict[str, Any]:
    """The ``metrics.json`` record of one replayed day (docs/outputs.md)."""
    st = res.state
    day = st.day
    routes = [r for p in res.plans for r in p.routes]
    energy = np.array([r.energy_j for r in routes]) if routes else np.zeros(0)
    flown = energy[energy > 0]
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
                unservable(day, st.depots.xy, model),
                strict=True,
            )
        ),
        "depot_load_kg": {str(i): round(float(load[i]), 6) for i in range(n_areas)},
        "battery_frac_mean": float(flown.mean() / model.cfg.battery_j) if flown.size else 0.0,
        "battery_frac_max": float(flown.max() / model.cfg.battery_j) if flown.size else 0.0,
        "energy_kj": total_j / 1000.0,
        "drones": res.n_drones,
        # The day objective: the windows' J and G summed (docs/method.md), in MJ.
        "objective_j_mj": sum(s.J for s in scores) / 1e6,
        "objective_g_mj": sum(s.G for s in scores) / 1e6,
        "delivered_share": float(delivered.mean()) if delivered.size else 1.0,
        "solver": {
            "calls": len(sel),
            "fallbacks": int(sum(s.fallback for s in sel)),
            "solve_s": float(sum(s.solve_s for s in sel)),
        },
    }
