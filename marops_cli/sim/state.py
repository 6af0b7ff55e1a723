"""Day state (paper eqs. 1–3): which requests are visible, delivered, and where drones are;
under an operating model also batteries, chargers and drones on long flights
(docs/method.md, "Operating model")."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..config import OpsConfig
from ..data.table import DayRequests
from ..energy import EnergyModel
from ..plans.ranges import Ties, delays_h, range_table
from ..plans.view import EVERY_DEPOT
from ..plans.window import WindowPlan
from ..policies.base import WindowView
from ..segment.depots import Depots
from .fleet import default_fleet
from .ops import Operations
from .reach import unservable_masks

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
        ops: OpsConfig | None = None,
        model: EnergyModel | None = None,
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
        # Requests no drone of the fleet can ever serve (each drone's type, else
        # ``model``'s; None: not known, every request counts as servable).
        self.model = model
        models = self.drone_models or ((model,) if model is not None else None)
        self.servable: np.ndarray | None = None
        if models:
            heavy, far = unservable_masks(day, depots.xy, list(dict.fromkeys(models)))
            self.servable = ~(heavy | far)
        self.ranges = range_table(depots, coverage)
        self.ties: Ties = ties
        self.delivered_w = np.full(len(day), -1, dtype=np.int64)
        self.arrive_s = np.full(len(day), np.nan)  # seconds from the delivering window's start
        self.waiting_w = np.zeros((day.n_windows, len(depots)), dtype=np.int64)
        """Parcels waiting per depot at the start of each window: its stock under
        ``stock = "home"``, else the pending requests of its service area."""
        self.ops: Operations | None = None
        if ops is not None:
            self.operate(ops)

    def operate(self, ops: OpsConfig) -> None:
        """Run the day under ``ops`` (the paper's model: nothing is tracked). A state
        keeps the model it started with: a different one is an error."""
        if self.ops is not None:
            if self.ops.cfg != ops:
                raise ValueError("the day already runs under another operating model")
            return
        if not ops.paper:
            n_depots = len(self.depots)
            self.ops = Operations(ops, n_depots, self.drone_depot.size, self.day.n_windows)

    def pending(self, t: int) -> np.ndarray:
        """Indices of requests visible at window t and not yet delivered (eq. 1)."""
        return np.flatnonzero((self.day.visible_w <= t) & (self.delivered_w < 0))

    def view(self, t: int) -> WindowView:
        idx = self.pending(t)
        ops = self.ops if self.ops is not None and self.ops.limited else None
        # What the run does not track is the paper's (WindowView.paper fills it in).
        return WindowView.paper(
            self.model,
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
            pending_stock=self.stock_depot(idx),
            pending_servable=None if self.servable is None else self.servable[idx],
            drone_ready=None if self.ops is None else self.ops.ready(t, self.drone_depot)[0],
            depot_spares=None if ops is None else ops.charged.copy(),
            depot_charging=None if ops is None else ops.charging(),
        )

    def stock_depot(self, idx: np.ndarray) -> np.ndarray:
        """The depot each of requests ``idx`` is stocked at: its service area's under
        ``stock = "home"``; :data:`EVERY_DEPOT` under the paper's model."""
        if self.ops is None or self.ops.cfg.stock != "home":
            return np.full(idx.size, EVERY_DEPOT, np.int64)
        return self.area[idx]

    def apply(self, plan: WindowPlan, speed_ms: float) -> None:
        """Deliver the plan's stops in window ``plan.t`` and move drones to their ends
        (at ``speed_ms``, or each drone's own speed in a mixed fleet); under an operating
        model, swap batteries, keep drones on long flights and charge (docs/method.md,
        "Operating model")."""
        ops, t = self.ops, plan.t
        if t < self.waiting_w.shape[0]:
            # Stock is the service area's under every model so far (stock_depot).
            waiting = self.area[self.pending(t)]
            self.waiting_w[t] = np.bincount(waiting, minlength=self.waiting_w.shape[1])
        if ops is not None:
            ops.start_window(t, self.drone_depot)
        w_s = self.day.window_s
        for r in plan.routes:
            speed = speed_ms if self.drone_models is None else self.drone_models[r.drone].speed_ms
            arrive = np.cumsum(r.legs_m) / speed
            # Under busy drones a parcel counts in the window it arrives in; else every
            # flight ends within its window (the paper's assumption 5).
            late = (arrive // w_s).astype(np.int64) if ops is not None and ops.cfg.busy else None
            for j, i in enumerate(r.stops):
                if self.delivered_w[i] >= 0:
                    raise RuntimeError(f"request {i} delivered twice")
                k = 0 if late is None else int(late[j])
                self.delivered_w[i] = t + k
                self.arrive_s[i] = arrive[j] - k * w_s
            if ops is not None:
                ops.fly(t, r.drone, r.end, r.energy_j, float(arrive[-1]) / w_s)
            self.drone_depot[r.drone] = r.end
        if ops is not None:
            ops.end_window(t, w_s)

    def delivery_delay_h(self) -> np.ndarray:
        """Delivery delay of each request (docs/method.md §5); undelivered count to the end."""
        t_end = np.where(self.delivered_w >= 0, self.delivered_w, self.day.n_windows)
        return np.maximum(0, t_end - self.day.due_w) * self.day.window_hours
