"""The layout-independent observation of a drone (docs/method.md §6), versioned.

One block of features per action candidate, so a trained actor works on any
segmentation with the same number of actions. Distances are in km; counts and
delays go through ``log1p`` so that one network fits a quiet suburb and a busy
city centre alike (a linear scale saturates the tanh units in one or the other).

Version history: 1 = six linear features per action; 2 = adds what the planner
would actually get for each action (its M̂ candidates' delay, count and detour),
how crowded the range is with other drones, and the map-wide overdue load;
3 = drones observe one after another (:class:`SequentialObserver`): requests the
best plans of the drones before have claimed are gone from every feature, and
each action also shows its best plan's net value and energy and how many drones
before already fly to its destination; 4 = version 3 plus what anticipation needs
(demand expected around each destination in the next windows from the history
days' arrival profile, today's arrivals there against that profile, the fleet there
after this window) and, as global inputs, α and the day's expected remaining
arrivals; 5 = version 4 seen with the drone's own type (a mixed fleet): its best plans
priced with its own energy model, payload and battery, and, as global inputs, its
payload limit, usable battery and speed over the reference drone's (the config's
``[energy]``; 1, 1, 1 for a fleet of one type). Versions 2, 3 and 4 stay for actors
trained on them.
"""

from __future__ import annotations

from collections.abc import Callable
from enum import IntEnum

import numpy as np

from ..config import PlanConfig
from ..energy import EnergyModel
from ..plans.candidates import by_delay, range_candidates
from ..plans.objective import lam_j
from ..plans.order import subset_energies
from ..plans.view import FREE
from .base import WindowView


class ObsVersion(IntEnum):
    """The observation versions this marops reads (the module docstring tells them apart);
    sidecars store the plain number (``obs_version``)."""

    MAPPO = 2  # every drone observes the same window at once (the MAPPO baseline's)
    SEQUENTIAL = 3  # drone by drone, each action with its best plan's value and energy
    ANTICIPATION = 4  # SEQUENTIAL, the free landing and the anticipation features
    CAPABILITIES = 5  # ANTICIPATION seen with the drone's own type (a mixed fleet)


OBS_VERSION = ObsVersion.ANTICIPATION  # what ``marops train`` writes for the flight-range actor
OBS_VERSIONS = tuple(ObsVersion)  # what the loaders read
PER_ACTION = 10  # features per action candidate, version 2
PER_ACTION_V3 = 13  # version 3: 10 as in version 2, then value, energy, drones heading there
PER_ACTION_V4 = 18  # version 4: 13 as in version 3, then 5 anticipation features
VALUE = 10  # index, within an action's block (versions 3, 4), of the best plan's net value
GLOBAL = 7  # time, own area (2), map (2), drones sharing my depot, fleet density
GLOBAL_V4 = 9  # version 4: 7 as before, then α and the day's expected remaining arrivals
GLOBAL_V5 = 12  # version 5: 9 as in version 4, then the drone's payload, battery and speed
M_HAT = 5  # candidates per drone the features assume (PlanConfig.max_parcels default)

Chooser = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""``choose(drones (k,), obs (k, D)) -> actions (k,)``: a policy's decision for some drones."""


def per_action(version: int) -> int:
    """Features per action candidate of observation ``version``."""
    if version == ObsVersion.MAPPO:
        return PER_ACTION
    return PER_ACTION_V3 if version == ObsVersion.SEQUENTIAL else PER_ACTION_V4


def n_choices(n_actions: int, version: int = OBS_VERSION) -> int:
    """Choices of a flight-range actor: the depot's ``n_actions`` destinations, and from
    version 4 on the free landing (:data:`~marops_cli.plans.view.FREE`), last."""
    return n_actions + (1 if version >= ObsVersion.ANTICIPATION else 0)


def obs_dim(n_actions: int, version: int = OBS_VERSION) -> int:
    n_global = (
        GLOBAL_V5
        if version >= ObsVersion.CAPABILITIES
        else GLOBAL_V4
        if version >= ObsVersion.ANTICIPATION
        else GLOBAL
    )
    return n_choices(n_actions, version) * per_action(version) + n_global


def choice_mask(view: WindowView, version: int = OBS_VERSION) -> np.ndarray:
    """``(U, n_choices)``: the view's action mask, plus the always-open free landing."""
    mask = view.action_mask()
    if version < ObsVersion.ANTICIPATION:
        return mask
    return np.hstack([mask, np.ones((mask.shape[0], 1), dtype=bool)])


def to_actions(choices: np.ndarray, n_actions: int) -> np.ndarray:
    """Choice indices -> planner actions: index ``n_actions`` (the free landing) is FREE."""
    c = np.asarray(choices, dtype=np.int64)
    return np.where(c == n_actions, FREE, c).astype(np.int64)


def _lg(x: float | np.ndarray) -> float | np.ndarray:
    return np.log1p(np.maximum(x, 0.0))


def _range_features(
    f: np.ndarray,
    view: WindowView,
    s: int,
    d: int,
    rng: np.ndarray,
    area: tuple[np.ndarray, np.ndarray, np.ndarray],
    neigh: np.ndarray,
    drones_at: np.ndarray,
    cand: np.ndarray,
    m_hat: int,
) -> None:
    """Write features 0-9 of the action s -> d with flight range ``rng`` into ``f`` (both
    versions): ``area`` holds the pending count, delay and due-now count per area,
    ``cand`` the pending positions of the range's M̂ candidates."""
    xy_s, xy_d = view.depots.xy[s], view.depots.xy[d]
    count, delay, due = area
    f[0] = np.hypot(*(xy_d - xy_s)) / 1000.0
    f[1] = _lg(count[rng].sum())
    f[2] = _lg(delay[rng].sum())
    f[3] = _lg(due[rng].sum())
    f[4] = _lg(neigh[d])
    f[5] = 1.0
    f[6] = _lg(drones_at[rng].sum() - 1.0)  # minus u itself: s is always in R
    if cand.size:
        pxy = view.pending_xy[cand]
        detour = np.hypot(*(pxy - xy_s).T) + np.hypot(*(pxy - xy_d).T) - np.hypot(*(xy_d - xy_s))
        f[7] = _lg(view.pending_delay_h[cand].sum())
        f[8] = cand.size / m_hat
        f[9] = detour.mean() / 1000.0


def observe(view: WindowView, m_hat: int = M_HAT) -> np.ndarray:
    """``(U, obs_dim)`` float32 observations, one row per drone.

    Per action candidate a of drone u (start s, destination d = candidates[s, a],
    flight range R = ranges[s, a]):

    0. distance s→d (km)
    1. log1p pending requests in R
    2. log1p summed delay in R (h)
    3. log1p requests due now or overdue in R
    4. log1p summed delay in the areas around d (its other candidates)
    5. valid flag (1)
    6. log1p other drones whose depot lies in R (crowding: they compete for R)
    7. log1p summed delay of the M̂ requests the planner would take in R (h)
    8. how many of those there are, / M̂
    9. their mean detour s→c→d minus s→d (km): what serving them costs

    Then: time of day (fraction of the day), log1p pending and delay in the own
    area, log1p pending and overdue delay on the whole map, drones at the same
    depot with a lower index (breaks the tie between co-located drones, which
    otherwise see the same thing and would pick the same action), and drones per
    depot.
    """
    dep = view.depots
    n, a = dep.candidates.shape
    area_count = np.bincount(view.pending_area, minlength=n).astype(np.float64)
    area_delay = np.bincount(view.pending_area, weights=view.pending_delay_h, minlength=n)
    due_now = (view.pending_due_w <= view.t).astype(np.float64)
    area_due = np.bincount(view.pending_area, weights=due_now, minlength=n)
    # Delay around each depot: the areas of its own candidate list, itself excluded.
    neigh_delay = area_delay[dep.candidates[:, 1:]].sum(axis=1) if a > 1 else np.zeros(n)
    drones_at = np.bincount(view.drone_depot, minlength=n).astype(np.float64)
    rank = by_delay(view)
    rank_area = view.pending_area[rank]

    out = np.zeros((view.n_drones, obs_dim(a, ObsVersion.MAPPO)), dtype=np.float32)
    for u, s in enumerate(view.drone_depot):
        s = int(s)
        for k in range(a):
            d = int(dep.candidates[s, k])
            rng = view.ranges[s, k]
            _range_features(
                out[u, k * PER_ACTION : (k + 1) * PER_ACTION],
                view,
                s,
                d,
                rng,
                (area_count, area_delay, area_due),
                neigh_delay,
                drones_at,
                range_candidates(view, rank, rank_area, s, k, m_hat),
                m_hat,
            )
        g = out[u, a * PER_ACTION :]
        g[0] = view.t / max(1, view.n_windows)
        g[1] = _lg(area_count[s])
        g[2] = _lg(area_delay[s])
        g[3] = _lg(area_count.sum())
        g[4] = _lg(view.pending_delay_h.sum())
        g[5] = _lg(float(np.count_nonzero(view.drone_depot[:u] == s)))
        g[6] = view.n_drones / max(1, n)
    return out


class SequentialObserver:
    """Observation version 3 of one window: drones observe and choose one after another.

    Drone u sees the pending requests less those claimed by the drones before it: a
    drone that chose action a claims the requests of its best plan for a (what the
    planner will most likely fly), so the next drone at the same depot sees what is
    left rather than the same crowd of overdue parcels. Per action candidate a of
    drone u (start s, destination d, range R), on the unclaimed requests:

    0–9. as version 2 (:func:`observe`), counts and delays of unclaimed requests
    10. the best plan's net value, (λ Σ v_c − E) / usable battery, over every
        feasible plan of the M̂ requests the planner would take in R (exact order,
        payload and battery as the planner); v_c = 1 + delay (h), λ = ((1 − α)/α) ·
        usable battery as in the selection. −1 when d is out of reach.
    11. that plan's energy / usable battery
    12. log1p drones before u that chose d as destination

    Then the 7 global features of version 2 (own area and map on unclaimed requests).

    Version 4 adds per action, with nb(d) = d's own candidate areas (d and its nearest
    depots) and the history days' arrival profile (``depots.arrivals``, zeros when
    unknown):

    13. log1p requests expected to become visible in d's area next window
    14. log1p requests expected in nb(d) over the next two windows
    15. log1p requests that became visible in nb(d) this window (today's rate)
    16. log((15's count + 1) / (expected this window in nb(d) + 1)): today against usual
    17. log1p drones in nb(d) after this window: those before u by their chosen
        destination, those after u (not yet decided) by their depot

    and as global inputs α and the share of the day's expected arrivals still to come
    (with no profile: the share of the day's windows still to come).

    Version 4 also has one more block, last: the free landing (no destination; the
    drone lands at the depot nearest its last customer). Its features are those of
    staying (d = s), except the best plan's value and energy, priced with that free
    end over the same candidates, and no drones heading there (12 = 0).
    """

    def __init__(
        self,
        view: WindowView,
        model: EnergyModel | None = None,
        plan: PlanConfig | None = None,
        alpha: float | None = None,
        version: int = ObsVersion.SEQUENTIAL,
    ) -> None:
        self.view = view
        self.version = version
        self.model = model or EnergyModel.of()
        self.plan = plan or PlanConfig()
        a = self.plan.alpha if alpha is None else alpha
        self.alpha = a
        self.lam = lam_j(a, self.model.usable_j)
        dep = view.depots
        self.n_depots, self.n_actions = dep.candidates.shape
        self.claimed = np.zeros(view.pending_idx.size, dtype=bool)
        self.heading = np.zeros(self.n_depots)  # drones before that chose each destination
        self.drones_at = np.bincount(view.drone_depot, minlength=self.n_depots).astype(float)
        self.rank = by_delay(view)
        self.due_now = (view.pending_due_w <= view.t).astype(np.float64)
        self._best: dict[int, np.ndarray] = {}  # action -> requests of the best plan (drone u)
        self._u = -1
        self._own = self.model  # the observed drone's energy model (version 5: its type's)
        self.dest = view.drone_depot.astype(np.int64).copy()  # chosen, or the depot if not yet
        if version >= ObsVersion.ANTICIPATION:
            self._anticipation()
            # Empty flight from each request to its nearest depot (its own area's).
            self.near_m = np.hypot(*(view.pending_xy - dep.xy[view.pending_area]).T)

    def _anticipation(self) -> None:
        """Per-depot demand expectations of version 4 (from the window, not the drone)."""
        v, n = self.view, self.n_depots
        t, n_w = v.t, v.n_windows
        prof = v.depots.arrivals
        if prof is None or prof.shape != (n, n_w):
            prof = np.zeros((n, n_w))
        nb = v.depots.candidates  # (N, A): each depot's neighbourhood, itself first
        nxt = prof[:, t + 1] if t + 1 < n_w else np.zeros(n)
        nxt2 = prof[:, t + 1 : t + 3].sum(axis=1)
        new = np.zeros(n, dtype=np.float64)
        if v.pending_visible_w is not None:
            is_new = (v.pending_visible_w == t).astype(np.float64)
            new = np.bincount(v.pending_area, weights=is_new, minlength=n).astype(np.float64)
        self.exp_next = nxt
        self.exp_nb2 = nxt2[nb].sum(axis=1)
        self.new_nb = new[nb].sum(axis=1)
        self.today_vs_usual = np.log((self.new_nb + 1.0) / (prof[:, t][nb].sum(axis=1) + 1.0))
        total = prof.sum()
        self.remaining = float(prof[:, t + 1 :].sum() / total) if total > 0 else 1.0 - (t + 1) / n_w

    @property
    def dim(self) -> int:
        return obs_dim(self.n_actions, self.version)

    def _best_plans(
        self, s: int, dests: list[int], cands: list[np.ndarray], free: bool = False
    ) -> list[tuple[float, float, np.ndarray]]:
        """(net value, energy, request positions) of the best plan s → cand → d of each
        action, priced in one batched dynamic program (:func:`subset_energies`); with
        ``free``, the last plan ends at the depot nearest its last customer instead (its
        ``dests`` entry is ``s``, where an empty plan stays)."""
        v, m = self.view, self._own
        n = max(1, max(c.size for c in cands))
        b = len(cands)
        xy = np.full((b, n, 2), np.nan)
        w = np.full((b, n), np.inf)
        val = np.zeros((b, n))
        for i, c in enumerate(cands):
            xy[i, : c.size], w[i, : c.size] = v.pending_xy[c], v.pending_weight[c]
            val[i, : c.size] = 1.0 + v.pending_delay_h[c]
        xy_s = np.repeat(v.depots.xy[s][None, :], b, axis=0)
        free_m = None
        if free:  # the other rows stay NaN: fixed ends
            free_m = np.full((b, n), np.nan)
            free_m[-1, : cands[-1].size] = self.near_m[cands[-1]]
        energy, _, bits = subset_energies(xy_s, v.depots.xy[dests], xy, w, m, free_m)
        net = self.lam * (val @ bits.T) - energy
        net[energy > m.usable_j] = -np.inf
        out = []
        for i, c in enumerate(cands):
            if not np.isfinite(net[i, 0]):  # even the empty flight s -> d is out of reach
                out.append((-m.usable_j, m.usable_j, c[:0]))
                continue
            k = int(np.argmax(net[i]))
            out.append((float(net[i, k]), float(energy[i, k]), c[bits[k, : c.size]]))
        return out

    def row(self, u: int) -> np.ndarray:
        """Drone u's observation, given what the drones before it claimed."""

        v, dep, m_hat = self.view, self.view.depots, self.plan.max_parcels
        s, n, a = int(v.drone_depot[u]), self.n_depots, self.n_actions
        self._own = self.model
        if self.version >= ObsVersion.CAPABILITIES:
            self._own = v.drone_models[u]  # its own type prices its plans
        free = ~self.claimed
        area = v.pending_area
        area_count = np.bincount(area, weights=free.astype(float), minlength=n)
        area_delay = np.bincount(area, weights=v.pending_delay_h * free, minlength=n)
        area_due = np.bincount(area, weights=self.due_now * free, minlength=n)
        neigh = area_delay[dep.candidates[:, 1:]].sum(axis=1) if a > 1 else np.zeros(n)
        areas = (area_count, area_delay, area_due)
        rank = self.rank[free[self.rank]]
        rank_area = area[rank]
        out = np.zeros(self.dim, dtype=np.float32)
        per = per_action(self.version)
        dests = [int(dep.candidates[s, k]) for k in range(a)]
        cands = [range_candidates(v, rank, rank_area, s, k, m_hat) for k in range(a)]
        blocks = list(range(a))
        if self.version >= ObsVersion.ANTICIPATION:  # the free landing, in the same call
            best = self._best_plans(s, [*dests, s], [*cands, cands[0]], free=True)
            fleet_after = np.bincount(self.dest, minlength=n).astype(float)
            fleet_after[s] -= 1.0  # u itself is counted where it goes, below
            blocks.append(a)
        else:
            best = self._best_plans(s, dests, cands)
        self._best, self._u = {k: best[k][2] for k in blocks}, u
        for k in blocks:
            is_free = k == a
            d = s if is_free else dests[k]
            kr = 0 if is_free else k
            net, energy, _ = best[k]
            f = out[k * per : (k + 1) * per]
            _range_features(
                f, v, s, d, v.ranges[s, kr], areas, neigh, self.drones_at, cands[kr], m_hat
            )
            f[VALUE] = net / self._own.usable_j
            f[VALUE + 1] = energy / self._own.usable_j
            f[VALUE + 2] = 0.0 if is_free else _lg(self.heading[d])
            if self.version >= ObsVersion.ANTICIPATION:
                f[13] = _lg(self.exp_next[d])
                f[14] = _lg(self.exp_nb2[d])
                f[15] = _lg(self.new_nb[d])
                f[16] = self.today_vs_usual[d]
                f[17] = _lg(fleet_after[dep.candidates[d]].sum())
        g = out[len(blocks) * per :]
        g[0] = v.t / max(1, v.n_windows)
        g[1] = _lg(area_count[s])
        g[2] = _lg(area_delay[s])
        g[3] = _lg(area_count.sum())
        g[4] = _lg(float((v.pending_delay_h * free).sum()))
        g[5] = _lg(float(np.count_nonzero(v.drone_depot[:u] == s)))
        g[6] = v.n_drones / max(1, n)
        if self.version >= ObsVersion.ANTICIPATION:
            g[7] = self.alpha
            g[8] = self.remaining
        if self.version >= ObsVersion.CAPABILITIES:  # the drone's type against the reference
            own, ref = self._own, self.model
            g[9] = own.max_payload_kg / ref.max_payload_kg
            g[10] = own.usable_j / ref.usable_j
            g[11] = own.speed_ms / ref.speed_ms
        return out

    def commit(self, u: int, action: int) -> None:
        """Drone u (the one last observed) chose ``action`` (a choice index; version 4's
        last is the free landing): claim its best plan."""
        assert u == self._u, "commit the drone last observed"
        self.claimed[self._best[int(action)]] = True
        s = int(self.view.drone_depot[u])
        free = self.version >= ObsVersion.ANTICIPATION and action == self.n_actions
        if free:  # lands near s, most likely
            self.dest[u] = s
            return
        d = int(self.view.depots.candidates[s, action])
        self.heading[d] += 1
        self.dest[u] = d


def observe_and_choose(
    view: WindowView,
    choose: Chooser,
    version: int = OBS_VERSION,
    *,
    model: EnergyModel | None = None,
    plan: PlanConfig | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """``(obs (U, D), actions (U,))`` of one window.

    Version 2: every drone observes the same window, one call of ``choose`` for all.
    Versions 3 and 4: drone by drone, in index order, each call for one drone
    (:class:`SequentialObserver`).
    """
    if version == ObsVersion.MAPPO:
        obs = observe(view)
        return obs, np.asarray(choose(np.arange(view.n_drones), obs), dtype=np.int64)
    seq = SequentialObserver(view, model, plan, version=version)
    obs = np.zeros((view.n_drones, seq.dim), dtype=np.float32)
    actions = np.zeros(view.n_drones, dtype=np.int64)
    for u in range(view.n_drones):
        obs[u] = seq.row(u)
        actions[u] = int(np.asarray(choose(np.array([u]), obs[u : u + 1])).reshape(-1)[0])
        seq.commit(u, int(actions[u]))
    return obs, actions


def best_value_action(
    obs: np.ndarray, mask: np.ndarray, version: int = ObsVersion.SEQUENTIAL
) -> np.ndarray:
    """Per row of version-3 (or 4) observations, the valid action whose best plan is worth
    most (ties to the lower index): the one-window best response, ``myopic``'s choice."""
    n_act = mask.shape[1]
    per = per_action(version)
    value = obs[:, [k * per + VALUE for k in range(n_act)]].astype(np.float64)
    value[~mask] = -np.inf
    return np.argmax(value, axis=1).astype(np.int64)
