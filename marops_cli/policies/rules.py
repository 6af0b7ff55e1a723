"""Landing rules an operator would try before a learned actor: backlog and rebalance
(docs/method.md §7). They matter under the operating model, where a drone carries only
the parcels stocked where it departs (docs/method.md, "Operating model").

Both choose among a drone's action candidates whose destination the empty drone can
reach (the planner's test, :func:`~marops_cli.plans.planner.can_reach`); a drone that
cannot fly this window stays (action 0). Both are deterministic.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

import numpy as np

from ..plans.planner import can_reach
from .base import PolicyBase, WindowView

if TYPE_CHECKING:
    from ..config import PlannerConfig
    from ..energy import EnergyModel

__all__ = ["BacklogPolicy", "EnergyAware", "RebalancePolicy", "reachable", "waiting_per_depot"]


def waiting_per_depot(view: WindowView, weights: np.ndarray | None = None) -> np.ndarray:
    """``(N,)`` the pending parcels (or their ``weights``) per depot: where each is
    stocked, or its service area's depot when every parcel is at every depot. Parcels no
    drone can ever serve are left out: nothing waits there for a drone to fetch."""
    where = view.pending_area if view.pending_stock is None else view.pending_stock
    n = len(view.depots)
    if view.pending_servable is not None:
        keep = view.pending_servable
        where = where[keep]
        weights = None if weights is None else np.asarray(weights)[keep]
    return np.bincount(where, weights=weights, minlength=n).astype(np.float64)[:n]


def reachable(view: WindowView, u: int, model: EnergyModel) -> np.ndarray:
    """``(A,)`` True where drone ``u``'s action leads to a destination it can reach empty;
    only action 0 (stay) for a drone that cannot fly this window."""
    ok = np.zeros(view.depots.candidates.shape[1], dtype=bool)
    ok[0] = True
    if view.ready(u):
        # The planner's own test, so no choice of a rule turns into stay.
        ok |= [can_reach(view, u, a, model) for a in range(ok.size)]
    return ok & view.action_mask()[u]


class EnergyAware(PolicyBase):
    """A rule that needs each drone's energy model to know what it can reach."""

    def __init__(self) -> None:
        from ..config import PlannerConfig

        EnergyAware.configure(self, PlannerConfig())  # the reference drone until configured

    def configure(self, cfg: PlannerConfig) -> None:
        """Use the run's energy model (a mixed fleet's drones bring their own)."""
        from ..energy import EnergyModel

        self._model = EnergyModel.of(cfg.energy)

    def reset(self, seed: int) -> None:
        pass

    def _drone_model(self, view: WindowView, u: int) -> EnergyModel:
        return self._model if view.drone_models is None else view.drone_models[u]


class BacklogPolicy(EnergyAware):
    """Land at the reachable depot with the most waiting value per drone already there.

    Waiting value of depot d: Σ (1 + delay h) over the pending parcels stocked at d (its
    service area's under ``stock = "any"``). Drones there: those at d that have not chosen
    yet, plus those that chose to land at d this window; drones choose in drone order and
    a drone does not count at its own depot while it chooses, so two drones share two
    equally loaded depots. Score value / (1 + drones there); ties to the lower action index.
    """

    name = "backlog"
    scope: Literal["range", "global"] = "range"

    def act(self, view: WindowView) -> np.ndarray:
        dep = view.depots
        out = np.zeros(view.n_drones, dtype=np.int64)
        value = waiting_per_depot(view, 1.0 + view.pending_delay_h)
        there = np.bincount(view.drone_depot, minlength=len(dep)).astype(np.float64)
        for u, s in enumerate(view.drone_depot):
            if not view.ready(u):
                continue  # it stays, and counts at its depot
            there[int(s)] -= 1.0
            dests = dep.candidates[int(s)]
            score = value[dests] / (1.0 + there[dests])
            score[~reachable(view, u, self._drone_model(view, u))] = -np.inf
            out[u] = int(np.argmax(score))  # first maximum: lower action index on ties
            there[int(dests[out[u]])] += 1.0
        return out


_STAY_COST = 1e9
"""Cost of a drone left out of the targets (it stays): above any flight in metres, so
the assignment fills every target a drone can reach first."""
_NO = 1e12
"""Cost of a destination the drone cannot take."""
_PER_ACTION = 1e-3
"""Metres added per action index: among equally distant destinations the lower index."""


def largest_remainder(share: np.ndarray, total: int) -> np.ndarray:
    """Integers summing to ``total`` proportional to ``share`` (≥ 0, not all 0): floors,
    then one more each to the largest remainders (ties to the lower index)."""
    exact = total * share / share.sum()
    out = np.floor(exact).astype(np.int64)
    order = np.argsort(-(exact - out), kind="stable")
    out[order[: total - int(out.sum())]] += 1
    return out


class RebalancePolicy(EnergyAware):
    """Min-cost assignment of drones to landing depots that match the coming demand.

    Demand of depot d: parcels waiting there (:func:`waiting_per_depot`) plus the
    requests expected in its service area over the next ``horizon`` windows on the
    history days' mean day (``depots.arrivals``; none when there is no history). The
    fleet is shared out proportionally (:func:`largest_remainder`); each target is a
    slot, and drone u takes slot d at the cost of the distance from its depot to d
    (+ 1 mm per action index), only where d is one of its reachable candidates (a drone
    that cannot fly only takes a slot at its own depot). A drone may instead stay at a
    cost above any flight, so the assignment (``scipy.optimize.linear_sum_assignment``)
    fills as many targets as the drones can reach, then flies the fewest metres. No
    demand anywhere: every drone stays.
    """

    name = "rebalance"
    scope: Literal["range", "global"] = "range"

    def __init__(self, horizon: int = 2) -> None:
        super().__init__()
        self.horizon = horizon

    def demand(self, view: WindowView) -> np.ndarray:
        """``(N,)`` waiting parcels plus expected arrivals over the next ``horizon``
        windows, per depot."""
        n = len(view.depots)
        out = waiting_per_depot(view)
        prof = view.depots.arrivals
        if prof is not None and prof.shape == (n, view.n_windows):
            out = out + prof[:, view.t + 1 : view.t + 1 + self.horizon].sum(axis=1)
        return out

    def act(self, view: WindowView) -> np.ndarray:
        from scipy.optimize import linear_sum_assignment

        dep, n_u = view.depots, view.n_drones
        out = np.zeros(n_u, dtype=np.int64)
        demand = self.demand(view)
        if n_u == 0 or demand.sum() <= 0:
            return out
        slots = np.repeat(np.arange(len(dep)), largest_remainder(demand, n_u))
        cost = np.full((n_u, 2 * n_u), _NO)
        cost[:, n_u:] = _STAY_COST
        for u, s in enumerate(view.drone_depot):
            dests = dep.candidates[int(s)]
            ok = reachable(view, u, self._drone_model(view, u))
            for a in np.flatnonzero(ok):
                d = int(dests[a])
                flight = float(np.hypot(*(dep.xy[d] - dep.xy[int(s)])))
                cost[u, :n_u][slots == d] = flight + _PER_ACTION * a
        rows, cols = linear_sum_assignment(cost)
        for u, j in zip(rows, cols, strict=True):
            if j < n_u:  # a slot it can take is one of its candidates
                dests = dep.candidates[int(view.drone_depot[u])]
                out[u] = int(np.flatnonzero(dests == slots[j])[0])
        return out
