"""Landing rules an operator would try before a learned actor: backlog, rebalance, flow
and battery (docs/method.md §7). They matter under the operating model, where a drone
carries only the parcels stocked where it departs and needs a charged battery where it
lands (docs/method.md, "Operating model").

All choose among a drone's action candidates whose destination the empty drone can
reach (the planner's test, :func:`~marops_cli.plans.planner.can_reach`); a drone that
cannot fly this window stays (action 0). All are deterministic.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

import numpy as np

from ..plans.planner import can_reach
from .base import PolicyBase, WindowView

if TYPE_CHECKING:
    from ..config import PlannerConfig
    from ..energy import EnergyModel

__all__ = [
    "BacklogPolicy",
    "BatteryPolicy",
    "EnergyAware",
    "FlowPolicy",
    "RebalancePolicy",
    "free_spares",
    "reachable",
    "waiting_per_depot",
]


def waiting_per_depot(view: WindowView, weights: np.ndarray | None = None) -> np.ndarray:
    """``(N,)`` the pending parcels (or their ``weights``) per depot: where each is
    stocked, or its service area's depot when every parcel is at every depot. Parcels no
    drone can ever serve are left out: nothing waits there for a drone to fetch."""
    where = view.waiting_at()
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
        return view.drone_models[u]


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
            score[~self._lands(view, int(s), dests, there)] = -np.inf
            out[u] = int(np.argmax(score))  # first maximum: lower action index on ties
            there[int(dests[out[u]])] += 1.0
        return out

    def _lands(self, view: WindowView, s: int, dests: np.ndarray, there: np.ndarray) -> np.ndarray:
        """``(A,)`` True where a drone at ``s`` may land (``there``: the drones counted at
        each depot, the choosing one left out): anywhere for ``backlog``."""
        return np.ones(dests.size, dtype=bool)


def free_spares(view: WindowView, there: np.ndarray) -> np.ndarray:
    """``(N,)`` charged spare batteries at each depot beyond one for each of the ``there``
    drones counted there (never below 0; ``inf`` where swaps are unlimited). A drone that
    flies to a depot lands without a charged battery (its own goes on charge there), so it
    flies on next window only where a spare is left for it."""
    return np.maximum(0.0, view.depot_spares.astype(np.float64) - there)


class BatteryPolicy(BacklogPolicy):
    """``backlog`` that never strands a drone: it lands at another depot only where a
    charged spare is left for it (:func:`free_spares`, with the drones counted as
    ``backlog`` counts them); staying is always allowed. Where swaps are unlimited it is
    ``backlog``."""

    name = "battery"

    def _lands(self, view: WindowView, s: int, dests: np.ndarray, there: np.ndarray) -> np.ndarray:
        free = free_spares(view, there)
        return (dests == s) | (free[dests] >= 1.0)


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


_TIE_KJ = 1e-3
"""Kilojoules added per depot id to a move: among equally good destinations, the lower
depot id (a perturbation far below any flight)."""


class FlowPolicy(EnergyAware):
    """A min-cost flow of the drones that can fly to the depots of the coming work, each
    window (the operations research standard for fleet repositioning).

    Work at depot d over the next ``horizon`` windows: the parcels waiting there
    (:func:`waiting_per_depot`) and the requests expected in its area (the arrival
    profile, ``depots.arrivals``), n(d) of them worth W(d) = Σ (1 + delay h) over the
    waiting ones + 1 per expected one. A drone carries ``c`` = ⌊payload / mean weight of
    the waiting parcels⌋ (at least 1) a window, so the k-th drone at d (k = 1, 2, …; the
    drones there that cannot fly hold the first) takes min(c·horizon, n(d) − (k − 1)·
    c·horizon) of them, at W(d) / n(d) each, worth λ (the window objective's price of
    delay, docs/method.md §4.2) per unit: shares that fall as drones are added. A depot
    keeps only as many drones flying as its chargers recharge batteries (:meth:`kept`):
    a share beyond them is worth nothing, its drone would soon wait for a battery.

    Each drone that can fly is one unit of supply at its depot; it may stay (cost 0) or
    fly to a reachable candidate d for the empty flight's energy (+ 1 J per depot id),
    and at most :func:`free_spares` of them land at d from elsewhere (the battery flow:
    a drone never lands where it would wait for a charged battery). The flow of least
    energy less the value of the shares filled, solved as a linear program by HiGHS
    (``scipy.optimize.linprog``; a network's program, so its optimum is integral), is the
    decision. A drone left with no share stays.
    """

    name = "flow"
    scope: Literal["range", "global"] = "range"

    def __init__(self, horizon: int = 2) -> None:
        from ..config import PlannerConfig

        self.horizon = horizon
        self.configure(PlannerConfig())

    def configure(self, cfg: PlannerConfig) -> None:
        """The run's energy model, α (λ) and the data's parcel weight."""
        from ..plans.objective import lam_j

        super().configure(cfg)
        self._lam_kj = lam_j(cfg.plan.alpha, self._model.usable_j) / 1000.0
        self._weight_kg = cfg.data.weight_median_kg
        self._chargers = float(cfg.ops.chargers_per_depot)
        self._charge_w = cfg.ops.charge_power_w

    def work(self, view: WindowView) -> tuple[np.ndarray, np.ndarray]:
        """``(N,)`` parcels to carry per depot over the next ``horizon`` windows, and
        ``(N,)`` their value (Σ 1 + delay h; 1 for each expected request)."""
        n = len(view.depots)
        count = waiting_per_depot(view)
        value = waiting_per_depot(view, 1.0 + view.pending_delay_h)
        prof = view.depots.arrivals
        if prof is not None and prof.shape == (n, view.n_windows):
            expected = prof[:, view.t + 1 : view.t + 1 + self.horizon].sum(axis=1)
            count, value = count + expected, value + expected
        return count, value

    def carry(self, view: WindowView) -> int:
        """Parcels a drone carries a window: the reference drone's payload over the mean
        weight of the waiting parcels (the data's median weight when none waits)."""
        keep = view.pending_servable
        w = view.pending_weight if keep is None else view.pending_weight[keep]
        mean = float(w.mean()) if w.size else self._weight_kg
        return max(1, int(self._model.max_payload_kg // max(mean, 1e-9)))

    def kept(self, view: WindowView) -> float:
        """Drones a depot keeps flying window after window (infinite where swaps are
        unlimited): each charger recharges a used battery a window at most, and the
        share of a usable battery its power restores in a window when that is less."""
        if view.swaps_unlimited:
            return np.inf
        restored = self._charge_w * view.window_h * 3600.0 / self._model.usable_j
        return self._chargers * min(1.0, restored)

    def act(
        self, view: WindowView, ready: list[int] | None = None, at: np.ndarray | None = None
    ) -> np.ndarray:
        """Each drone's action; ``ready``: the drones the flow plans (by default every
        drone that can fly; the others stay), ``at``: ``(N,)`` the drones counted at each
        depot, the planned ones at their own (by default where every drone is)."""
        n = len(view.depots)
        if ready is None:
            ready = [u for u in range(view.n_drones) if view.ready(u)]
        if at is None:
            at = np.bincount(view.drone_depot, minlength=n).astype(np.float64)[:n]
        return self._plan(view, ready, at)

    def _plan(self, view: WindowView, ready: list[int], at: np.ndarray) -> np.ndarray:
        from scipy.optimize import linprog
        from scipy.sparse import coo_array

        dep, n = view.depots, len(view.depots)
        out = np.zeros(view.n_drones, dtype=np.int64)
        count, value = self.work(view)
        if not ready or count.sum() <= 0:
            return out
        held = at - np.bincount(view.drone_depot[ready], minlength=n)[:n]
        spares = free_spares(view, at)
        cap = np.minimum(spares, len(ready))
        # Variables: each ready drone's allowed actions, then per depot the movers landing
        # (≤ cap), the shares (≤ 1 each) and the drones left over.
        cost: list[float] = []
        rows: list[int] = []
        cols: list[int] = []
        vals: list[float] = []
        upper: list[float] = []
        arcs: list[tuple[int, int]] = []  # (drone, action) of each drone variable

        def var(c: float, hi: float, *entries: tuple[int, float]) -> None:
            for r, v in entries:
                rows.append(r)
                cols.append(len(cost))
                vals.append(v)
            cost.append(c)
            upper.append(hi)

        # Rows: one per ready drone, then depot d's movers (len(ready) + d) and its
        # balance (len(ready) + n + d).
        mover, balance = len(ready), len(ready) + n
        for i, u in enumerate(ready):
            s = int(view.drone_depot[u])
            model = self._drone_model(view, u)
            dests = dep.candidates[s]
            for a in np.flatnonzero(reachable(view, u, model)):
                d = int(dests[a])
                if d == s:
                    var(0.0, 1.0, (i, 1.0), (balance + d, 1.0))
                elif cap[d] >= 1.0:
                    flight = float(np.hypot(*(dep.xy[d] - dep.xy[s])))
                    kj = float(model.leg_energy_j(flight, 0.0)) / 1000.0 + _TIE_KJ * d
                    var(kj, 1.0, (i, 1.0), (mover + d, 1.0))
                else:
                    continue
                arcs.append((u, int(a)))
        n_arcs = len(cost)
        share = self.carry(view) * self.horizon
        kept = self.kept(view)
        for d in range(n):
            var(0.0, cap[d], (mover + d, -1.0), (balance + d, 1.0))
            per = value[d] / count[d] if count[d] > 0 else 0.0
            for k in range(int(held[d]), int(held[d]) + len(ready)):
                if count[d] <= k * share or kept <= k:
                    break  # no work left for it, or no battery
                take = min(share, count[d] - k * share) * min(1.0, kept - k)
                var(-self._lam_kj * per * take, 1.0, (balance + d, -1.0))
            var(0.0, np.inf, (balance + d, -1.0))
        n_rows = len(ready) + 2 * n
        a_eq = coo_array((vals, (rows, cols)), shape=(n_rows, len(cost))).tocsr()
        b_eq = np.zeros(n_rows)
        b_eq[: len(ready)] = 1.0
        res = linprog(
            cost, A_eq=a_eq, b_eq=b_eq, bounds=list(zip([0.0] * len(cost), upper, strict=True)),
            method="highs-ds",
        )  # fmt: skip
        if res.status != 0:  # staying is always feasible: not expected
            return out
        # The program's optimum is integral: each drone's one arc at 1.
        for (u, action), flow in zip(arcs, res.x[:n_arcs], strict=True):
            if flow > 0.5:
                out[u] = action
        return out
