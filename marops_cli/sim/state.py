"""Day state (paper eqs. 1–3): which requests are visible, delivered, and where drones are."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..data.table import DayRequests
from ..energy import EnergyModel
from ..plans.ranges import Ties, delays_h, range_table
from ..plans.window import WindowPlan
from ..policies.base import WindowView
from ..segment.depots import Depots
from .fleet import default_fleet

__all__ = ["DayState", "default_fleet"]


class DayState:
    """Requests of one day and the fleet, advanced window by window.

    ``delivered_w[i]`` is the window request ``i`` was delivered in, or -1.
    """

    def __init__(
        self,
        day: DayRequests,
        depots: Depots,
        drone_depot: np.ndarray,
        coverage: float,
        ties: Ties = "nearest",
        drone_models: Sequence[EnergyModel] | None = None,
    ) -> None:
        self.day = day
        self.depots = depots
        self.area = depots.assign(day.x_m, day.y_m)
        self.xy = np.column_stack([day.x_m, day.y_m])
        self.drone_depot = np.asarray(drone_depot, dtype=np.int64).copy()
        # Each drone's type (speed, payload, battery); None: one type, the planner's model.
        self.drone_models = None if drone_models is None else tuple(drone_models)
        if self.drone_models is not None and len(self.drone_models) != self.drone_depot.size:
            raise ValueError("one energy model per drone expected")
        self.ranges = range_table(depots, coverage)
        self.ties: Ties = ties
        self.delivered_w = np.full(len(day), -1, dtype=np.int64)
        self.arrive_s = np.full(len(day), np.nan)  # seconds from the delivering window's start

    def pending(self, t: int) -> np.ndarray:
        """Indices of requests visible at window t and not yet delivered (eq. 1)."""
        return np.flatnonzero((self.day.visible_w <= t) & (self.delivered_w < 0))

    def view(self, t: int) -> WindowView:
        idx = self.pending(t)
        return WindowView(
            t=t,
            n_windows=self.day.n_windows,
            window_h=self.day.window_hours,
            depots=self.depots,
            ranges=self.ranges,
            drone_depot=self.drone_depot.copy(),
            pending_idx=idx,
            pending_xy=self.xy[idx],
            pending_area=self.area[idx],
            pending_delay_h=delays_h(self.day.due_w[idx], t, self.day.window_hours),
            pending_due_w=self.day.due_w[idx],
            pending_due_s=self.day.due_s[idx],
            pending_weight=self.day.weight_kg[idx],
            ties=self.ties,
            pending_visible_w=self.day.visible_w[idx],
            drone_models=self.drone_models,
        )

    def apply(self, plan: WindowPlan, speed_ms: float) -> None:
        """Deliver the plan's stops in window ``plan.t`` and move drones to their ends
        (at ``speed_ms``, or each drone's own speed in a mixed fleet)."""
        for r in plan.routes:
            speed = speed_ms if self.drone_models is None else self.drone_models[r.drone].speed_ms
            arrive = np.cumsum(r.legs_m) / speed
            for j, i in enumerate(r.stops):
                if self.delivered_w[i] >= 0:
                    raise RuntimeError(f"request {i} delivered twice")
                self.delivered_w[i] = plan.t
                self.arrive_s[i] = arrive[j]
            self.drone_depot[r.drone] = r.end

    def delivery_delay_h(self) -> np.ndarray:
        """Delivery delay of each request (docs/method.md §5); undelivered count to the end."""
        t_end = np.where(self.delivered_w >= 0, self.delivered_w, self.day.n_windows)
        return np.maximum(0, t_end - self.day.due_w) * self.day.window_hours
