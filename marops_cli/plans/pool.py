"""Route pool: many good, feasible routes per drone for the selection program.

docs/method.md, "Route pool", explains the method; in short, for one window:

1. **Candidates.** Each drone may serve the pending requests it is allowed to (its
   flight range, or the whole map) that it can reach alone within the battery; the
   ``pool_candidates`` best by *value density* (prize over the share of payload and
   battery one visit uses) are kept.
2. **Construction.** Parallel best insertion over all drones at once with the exact
   payload-aware energy (eq. (6): every leg before the new stop carries its parcel
   too): the (drone, request, position) with the best score is inserted, as long as
   payload and battery allow and the prize λ·v exceeds the extra energy. Scores:
   ``weight`` (gain per kilogram), ``gain`` (prize − extra energy) and ``density``
   (gain per share of payload and battery used). Each construction is a complete,
   conflict-free plan of the window.
3. **Exchange.** In the best construction each route swaps a stop for the best
   unserved candidate that fits once the stop is out, while its G grows.
   **Improvement.** Ruin and recreate (large neighbourhood search) with three ruins
   in turn: of one route (with a relocation to another drone), of the served stops
   nearest a random one over up to three routes, and of the stops whose detour
   costs the most energy; the touched routes are refilled greedily with blurred
   scores; a result is kept when G grows or is within a falling threshold of the
   current one; the best solution's routes get the exchange once more.
   Deterministic: the random stream is seeded.
4. **Pool.** Every route any of these solutions gave a drone is a column; the
   selection program then picks one per drone, each request at most once, so its
   result is never worse than the best single solution.

Routes are stored in insertion order with their exact energy; the chosen ones are
re-ordered for energy by the exact subset dynamic program afterwards
(:func:`finish_route`), which only lowers energy.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..energy import ENERGY_TOL_J, PAYLOAD_TOL_KG, EnergyModel
from ..segment.depots import nearest_depot
from .kernels import kernels
from .order import MAX_STOPS, evaluate_orders, exact_orders, node_distances, subset_masks
from .problem import DroneTask, WindowProblem

__all__ = ["DroneTask", "PoolResult", "RoutePool", "build_pool", "finish_route"]
SCORES = ("weight", "density", "gain")
_Route = tuple[tuple[int, ...], float, float, float]  # stops, energy, weight, prizes
_ACCEPT = 0.01  # ruin and recreate accepts a solution up to this share of G worse, falling to 0
_RUIN_MAX = 8  # the nearest-stops and worst-detour ruins free 2 to this many stops
_BLINK = 0.5  # ruin and recreate refills by each insertion's score times U(1 - _BLINK, 1)
_NOISE = 0.5  # the worst-detour ruin ranks each stop's saving times U(_NOISE, 1)
_EXACT_MAX = 10  # exact re-ordering up to this many stops (2**10 subsets)
_SEED_TRIES = 3  # an empty route tries this many seeds (:meth:`RoutePool._seed`)
_SEED_NEAR = 8  # a seed is rated with this many of its best neighbours
# np.interp's compiled core: the same values without the wrapper's checks, which cost as
# much as the interpolation itself on the search's small arrays.
_interp = getattr(np, "_core", np).multiarray.interp
_NO_BLUR = np.zeros(0)  # the compiled refresh's "scores not blurred"


def _best(score: NDArray[np.float64]) -> tuple[float, int]:
    """The highest score and its index (the first of equals); (−inf, 0) when empty."""
    if not score.size:
        return -np.inf, 0
    j = int(score.argmax())
    return float(score[j]), j


@dataclass(frozen=True)
class _Kind:
    """What the search needs of a drone type: payload, usable battery, energy per metre."""

    model: EnergyModel
    cap: float
    usable: float
    """The battery the search plans within: the usable battery less the tolerance, so
    that energies added up insertion by insertion still fit once recomputed."""
    e0: float  # J/m empty
    fit_kg: float
    """The heaviest load the payload limit admits (``EnergyModel.fits``' tolerance)."""
    grid: NDArray[np.float64]
    table: NDArray[np.float64]

    @classmethod
    def of(cls, model: EnergyModel) -> _Kind:
        return cls(
            model,
            model.max_payload_kg,
            model.usable_j - ENERGY_TOL_J,
            float(model.energy_per_m(0.0)),
            model.max_payload_kg + PAYLOAD_TOL_KG,
            model.grid_kg,
            model.table_j_per_m,
        )

    def e(self, load: NDArray[np.float64] | float) -> NDArray[np.float64]:
        """Energy per metre with ``load`` kg on board (the model's own table, unchecked)."""
        return _interp(load, self.grid, self.table)

    @cached_property
    def limits(self) -> tuple[float, float, float, NDArray[np.float64], NDArray[np.float64]]:
        """What the compiled kernels read of the type (:data:`._jit.Limits`)."""
        return (self.cap, self.fit_kg, self.usable, self.grid, self.table)


@dataclass
class _Drone:
    """A drone's candidates and its route under construction."""

    k: _Kind
    start_xy: NDArray[np.float64]
    cand: NDArray[np.int64]  # positions
    cand_xy: NDArray[np.float64]
    cand_w: NDArray[np.float64]
    cand_prize: NDArray[np.float64]
    dmat: NDArray[np.float64]  # (m, m + 1) distances candidate -> candidate, or -> start
    cand_end: NDArray[np.float64]  # energy of the empty last leg from each candidate
    start_end: float  # ... and from the start (the empty route)
    seedable: bool = False  # some candidate does not pay alone: an empty route is seeded
    stops: list[int] = field(default_factory=list)  # indices into cand
    energy: float = 0.0
    weight: float = 0.0
    psum: float | None = 0.0  # prizes of the stops; None whenever ``stops`` change
    # cached best insertion per candidate
    score: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    slot: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    d_e: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))

    @cached_property
    def arrays(self) -> tuple[Any, ...]:
        """What the compiled kernels read of the drone (:data:`._jit.Drone`)."""
        return (self.dmat, self.cand_w, self.cand_end, self.start_end, self.cand, self.cand_prize)

    @cached_property
    def best(self) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
        """The cached best insertions, filled in place (:data:`._jit.Best`)."""
        return (self.score, self.slot, self.d_e)


@dataclass(frozen=True)
class PoolResult:
    """Each drone's distinct routes (positions in insertion order) with their energy."""

    routes: list[list[tuple[int, ...]]]
    energy_j: list[list[float]]
    best_g: float
    """G of the best single conflict-free solution found (the selection does at least as well)."""


class RoutePool:
    """Builds the route pool of one window (module docstring)."""

    def __init__(self, problem: WindowProblem, n_candidates: int = 80) -> None:
        """The pool of ``problem``'s drones, built for the prizes ``problem.search``;
        each drone keeps its ``n_candidates`` best requests (and those it is home to)."""
        tasks = list(problem.tasks)
        kinds: dict[int, _Kind] = {}  # one per energy model (drone type)
        self.kinds = [kinds.setdefault(id(t.model), _Kind.of(t.model)) for t in tasks]
        self.w = np.asarray(problem.weight, dtype=np.float64)
        self.prize = np.asarray(problem.search, dtype=np.float64)
        self.xy = np.asarray(problem.xy, dtype=np.float64)
        self.depots_xy = np.asarray(problem.depots_xy, dtype=np.float64)
        self.tasks = tasks
        self._jit = kernels()  # the compiled insertion (the same results), or None
        self._near_m: NDArray[np.float64] | None = None
        # (drone, stops) -> the route's energy without each stop (the worst-detour ruin)
        self._without_j: dict[tuple[int, tuple[int, ...]], NDArray[np.float64]] = {}
        scored = [self._score_alone(t, k) for t, k in zip(tasks, self.kinds, strict=True)]
        # Each request's "home" drone: the one it suits best (highest value density; ties
        # to the lower drone). A drone keeps its ``n_candidates`` best requests and also
        # the requests it is home to (up to as many again), so every request some drone
        # can serve is a candidate of at least one drone, however far or heavy it is.
        best = np.full(self.w.size, -np.inf)
        home = np.full(self.w.size, -1, dtype=np.int64)
        for u, (pos, density, _) in enumerate(scored):
            better = density > best[pos]
            best[pos[better]] = density[better]
            home[pos[better]] = u
        self.drones = [
            self._drone(t, self.kinds[u], sc, home, u, n_candidates)
            for u, (t, sc) in enumerate(zip(tasks, scored, strict=True))
        ]
        self._can = np.zeros((len(tasks), self.w.size), dtype=bool)  # drone may serve request
        self._index = [{int(q): j for j, q in enumerate(dr.cand)} for dr in self.drones]
        for u, dr in enumerate(self.drones):
            self._can[u, dr.cand] = True

    def _end_m(self, xy: NDArray[np.float64], end: int) -> NDArray[np.float64]:
        """Length of the last leg from each point to the drone's end."""
        if end >= 0:
            return np.hypot(*(xy - self.depots_xy[end]).T)
        return nearest_depot(xy, self.depots_xy)[1]

    def _score_alone(
        self, task: DroneTask, k: _Kind
    ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
        """The requests a drone can serve alone at a profit: positions, density, last leg."""
        s_xy = self.depots_xy[task.start]
        pos = np.asarray(task.allowed, dtype=np.int64)
        xy = self.xy[pos]
        if task.end >= 0:
            end_e = self._end_m(xy, task.end) * k.e0
        else:
            if self._near_m is None:  # once for every drone that lands freely
                self._near_m = self._end_m(self.xy, -1)
            end_e = self._near_m[pos] * k.e0
        start_end = float(self._end_m(s_xy[None, :], task.end)[0] * k.e0)
        w = self.w[pos]
        # Alone: start -> request with its parcel -> end empty.
        alone = np.hypot(*(xy - s_xy).T) * k.e(np.minimum(w, k.cap)) + end_e
        gain = self.prize[pos] - (alone - start_end)
        use = w / k.cap + np.maximum(alone - start_end, 0.0) / k.usable
        # A request that does not pay for a flight of its own may still pay in a route
        # with its neighbours (a high α prices delay low): it is a candidate too, ranked
        # after every one that pays alone (by its gain), and only a seed starts a route
        # with it (:meth:`_seed`).
        density = np.where(gain > 0, gain / np.maximum(use, 1e-9), gain)
        keep = np.flatnonzero(k.model.fits(w) & (alone <= k.usable))
        return pos[keep], density[keep], end_e[keep]

    def _drone(
        self,
        task: DroneTask,
        k: _Kind,
        scored: tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]],
        home: NDArray[np.int64],
        u: int,
        n_candidates: int,
    ) -> _Drone:
        s_xy = self.depots_xy[task.start]
        pos, density, end_e = scored
        start_end = float(self._end_m(s_xy[None, :], task.end)[0] * k.e0)
        # Best density first; ties to the lower position, so array order never matters.
        rank = np.lexsort((pos, -density))
        top = rank[:n_candidates]
        rest = rank[n_candidates:]
        extra = rest[home[pos[rest]] == u][:n_candidates]
        keep = np.concatenate([top, extra])
        keep = keep[np.argsort(pos[keep], kind="stable")]  # by position (searchsorted)
        cxy = self.xy[pos[keep]]
        nodes = np.vstack([cxy, s_xy[None, :]])
        dmat = np.hypot(cxy[:, None, 0] - nodes[None, :, 0], cxy[:, None, 1] - nodes[None, :, 1])
        return _Drone(
            k,
            s_xy,
            pos[keep],
            cxy,
            self.w[pos[keep]],
            self.prize[pos[keep]],
            dmat,
            end_e[keep],
            start_end,
            seedable=bool((density[keep] <= 0).any()),
            energy=start_end,
            score=np.full(keep.size, -np.inf),
            slot=np.zeros(keep.size, dtype=np.int64),
            d_e=np.zeros(keep.size),
        )

    # -- insertion -----------------------------------------------------------------------

    def _insertion(
        self, dr: _Drone, sub: NDArray[np.int64]
    ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Least extra energy to insert each candidate in ``sub`` into the route, and
        where (slot i: after the i-th node, the start being node 0)."""
        k = len(dr.stops)
        m = sub.size
        if m == 0:
            return np.zeros(0), np.zeros(0, dtype=np.int64)
        if self._jit is not None:
            out = np.empty(m), np.empty(m, dtype=np.int64)
            stops_a = np.array(dr.stops, dtype=np.int64)
            self._jit.insertion(dr.arrays, stops_a, sub, dr.k.limits, out)
            return out
        wq = dr.cand_w[sub]
        if k == 0:  # start -> q with its parcel -> end empty
            d_e = dr.dmat[sub, -1] * dr.k.e(np.minimum(wq, dr.k.cap))
            return d_e + dr.cand_end[sub] - dr.start_end, np.zeros(m, dtype=np.int64)
        stops = np.array(dr.stops)
        nodes = np.empty(k + 1, dtype=np.int64)
        nodes[0], nodes[1:] = dr.cand.size, stops
        load = np.zeros(k + 1)  # L_i leaving node i, i = 0..k
        load[:k] = dr.cand_w[stops][::-1].cumsum()[::-1]
        dq = dr.dmat.take(nodes, axis=1).take(sub, axis=0)  # (m, k + 1): node i -> q
        e_l = dr.k.e(load)
        e_lq = dr.k.e(np.minimum(load[None, :] + wq[:, None], dr.k.cap))  # (m, k + 1)
        legs = dr.dmat[stops, nodes[:-1]]  # (k,): node i -> node i + 1
        # Inserting q after node i: the legs before it carry q's parcel too (prefix),
        # node i -> q -> node i + 1 replaces node i -> node i + 1.
        d_e = dq * e_lq
        d_e[:, 1:] += ((e_lq[:, :k] - e_l[None, :k]) * legs[None, :]).cumsum(axis=1)
        d_e[:, :k] += dq[:, 1:] * e_l[None, :k] - (legs * e_l[:k])[None, :]
        d_e[:, k] += dr.cand_end[sub] - dr.cand_end[stops[-1]]
        at = d_e.argmin(axis=1)
        return d_e[np.arange(m), at], at

    def _refresh(
        self,
        u: int,
        score_kind: str,
        free: NDArray[np.bool_],
        rng: np.random.Generator | None = None,
    ) -> tuple[float, int]:
        """Each free candidate's best insertion into drone ``u``'s route and its score;
        with ``rng`` the scores are blurred (a random factor in [1 − _BLINK, 1]), so that
        a refill need not rebuild what was ruined. Returns the best score and its
        candidate (the first of equals; −inf when none may be inserted)."""
        dr = self.drones[u]
        # A blur factor per candidate (drawn whether it is free or not, so that the
        # compiled loop can pick the free ones itself).
        blur = _NO_BLUR if rng is None else rng.uniform(1.0 - _BLINK, 1.0, dr.cand.size)
        if self._jit is not None:  # the same as below, in one compiled loop
            route = (np.array(dr.stops, dtype=np.int64), dr.weight, dr.energy)
            scoring = (self._jit.KIND[score_kind], blur)
            return self._jit.refresh(dr.arrays, dr.k.limits, route, free, dr.best, scoring)
        sub = (free[dr.cand] & (dr.weight + dr.cand_w <= dr.k.fit_kg)).nonzero()[0]
        d_e, slot = self._insertion(dr, sub)
        gain = dr.cand_prize[sub] - d_e
        feas = (dr.energy + d_e <= dr.k.usable) & (gain > 0)
        if score_kind == "density":
            use = dr.cand_w[sub] / dr.k.cap + np.maximum(d_e, 0.0) / dr.k.usable
            score = gain / np.maximum(use, 1e-9)
        elif score_kind == "weight":
            score = gain / np.maximum(dr.cand_w[sub], 1e-9)
        else:
            score = gain
        if rng is not None:
            score = score * blur[sub]
        dr.score.fill(-np.inf)  # only the scores of ``sub`` are read, slots and energies too
        dr.score[sub] = np.where(feas, score, -np.inf)
        dr.slot[sub] = slot
        dr.d_e[sub] = d_e
        return _best(dr.score)

    def _insert(self, u: int, j: int) -> None:
        dr = self.drones[u]
        dr.stops.insert(int(dr.slot[j]), j)
        dr.psum = None
        dr.energy += float(dr.d_e[j])
        dr.weight += float(self.w[dr.cand[j]])

    def _fill(
        self,
        users: list[int],
        score_kind: str,
        free: NDArray[np.bool_],
        rng: np.random.Generator | None = None,
        seed: bool = True,
    ) -> None:
        """Greedy insertion into the routes of ``users`` until nothing profitable fits
        (scores blurred with ``rng``, :meth:`_refresh`); then each drone left empty whose
        candidates do not all pay alone gets a seeded route when one pays
        (:meth:`_seed`; not with ``seed`` False)."""
        best, at = [], []  # each drone's best score and its candidate
        for u in users:
            b, j = self._refresh(u, score_kind, free, rng)
            best.append(b)
            at.append(j)
        while best and max(best) > -np.inf:
            i = best.index(max(best))  # ties to the first drone
            u = users[i]
            dr = self.drones[u]
            q = int(dr.cand[at[i]])
            self._insert(u, at[i])
            free[q] = False
            best[i], at[i] = self._refresh(u, score_kind, free, rng)
            for i2, u2 in enumerate(users):  # q is taken: no other drone may insert it
                hit = self._index[u2].get(q, -1) if u2 != u else -1
                if hit >= 0:
                    d2 = self.drones[u2]
                    if d2.score[hit] > -np.inf:
                        d2.score[hit] = -np.inf
                        if hit == at[i2]:  # it was that drone's best
                            best[i2], at[i2] = _best(d2.score)
        if seed:
            for u in users:
                if self.drones[u].seedable and not self.drones[u].stops:
                    self._seed(u, score_kind, free, rng)

    def _seed(
        self,
        u: int,
        score_kind: str,
        free: NDArray[np.bool_],
        rng: np.random.Generator | None,
    ) -> None:
        """Start drone ``u``'s empty route at a request that does not pay alone.

        Greedy insertion never opens a route with a request whose prize is below its
        flight (insertions must gain), so where delay is priced low no route would start
        although a cluster of such requests pays together. Each free candidate is rated
        by its gain alone plus what its ``_SEED_NEAR`` best neighbours would add (prize
        less a there-and-back detour); the ``_SEED_TRIES`` best with a positive rating
        each start a route that is then filled greedily, and the route of highest G is
        kept if its G is positive (else the route stays empty)."""
        dr = self.drones[u]
        sub = (free[dr.cand] & (dr.cand_w <= dr.k.fit_kg)).nonzero()[0]
        if not sub.size:
            return
        d_e, _ = self._insertion(dr, sub)
        gain = dr.cand_prize[sub] - d_e
        pair_w = np.minimum(dr.cand_w[sub][:, None] + dr.cand_w[sub][None, :], dr.k.cap)
        add = dr.cand_prize[sub][None, :] - 2.0 * dr.dmat[np.ix_(sub, sub)] * dr.k.e(pair_w)
        np.fill_diagonal(add, 0.0)
        add = np.maximum(add, 0.0)
        if add.shape[1] > _SEED_NEAR:
            add = np.partition(add, add.shape[1] - _SEED_NEAR, axis=1)[:, -_SEED_NEAR:]
        rating = gain + add.sum(axis=1)
        order = np.lexsort((sub, -rating))[:_SEED_TRIES]
        best: tuple[float, list[int], float, float] | None = None
        for i in order[rating[order] > 0].tolist():
            j = int(sub[i])
            dr.slot[j], dr.d_e[j] = 0, d_e[i]
            self._insert(u, j)
            free[dr.cand[j]] = False
            self._fill([u], score_kind, free, rng, seed=False)
            g = self._psum(dr) - (dr.energy - dr.start_end)
            if g > 1e-9 and (best is None or g > best[0] + 1e-9):
                best = (g, list(dr.stops), dr.energy, dr.weight)
            free[dr.cand[dr.stops]] = True
            dr.stops, dr.energy, dr.weight, dr.psum = [], dr.start_end, 0.0, None
        if best is not None:
            _, dr.stops, dr.energy, dr.weight = best
            dr.psum = None
            free[dr.cand[dr.stops]] = False

    # -- solutions -----------------------------------------------------------------------

    def _reset(self) -> NDArray[np.bool_]:
        for dr in self.drones:
            dr.stops, dr.energy, dr.weight, dr.psum = [], dr.start_end, 0.0, None
        return np.ones(self.w.size, dtype=bool)

    def _psum(self, dr: _Drone) -> float:
        if dr.psum is None:
            dr.psum = float(dr.cand_prize[dr.stops].sum())
        return dr.psum

    def _g(self) -> float:
        """G of the current routes: prizes served less every drone's energy."""
        return float(sum(self._psum(dr) - dr.energy for dr in self.drones))

    def _state(self, u: int) -> _Route:
        dr = self.drones[u]
        return (tuple(dr.stops), dr.energy, dr.weight, self._psum(dr))

    def _snapshot(self) -> list[_Route]:
        return [self._state(u) for u in range(len(self.drones))]

    def _restore(self, snap: list[_Route]) -> NDArray[np.bool_]:
        free = np.ones(self.w.size, dtype=bool)
        for dr, (stops, e, w, ps) in zip(self.drones, snap, strict=True):
            dr.stops, dr.energy, dr.weight, dr.psum = list(stops), e, w, ps
            free[dr.cand[list(stops)]] = False
        return free

    def _restore_some(self, snap: list[_Route], users: list[int], free: NDArray[np.bool_]) -> None:
        """Put the routes of ``users`` back as in ``snap`` (the others are as there)."""
        for u in users:
            dr = self.drones[u]
            free[dr.cand[dr.stops]] = True
        for u in users:
            dr = self.drones[u]
            stops, dr.energy, dr.weight, dr.psum = snap[u]
            dr.stops = list(stops)
            free[dr.cand[dr.stops]] = False

    def _remove(self, u: int, drop: list[int]) -> None:
        """Remove stops (indices into the route) and recompute energy exactly."""
        dr = self.drones[u]
        gone = set(drop)
        dr.stops = [j for i, j in enumerate(dr.stops) if i not in gone]
        dr.psum = None
        dr.energy = self._route_energy(dr)
        dr.weight = float(self.w[dr.cand[dr.stops]].sum())

    def _route_energy(self, dr: _Drone) -> float:
        """The route's exact energy: its legs' in route order (a running sum, as the
        compiled one adds them), then the empty last leg."""
        if not dr.stops:
            return dr.start_end
        stops = np.array(dr.stops, dtype=np.int64)
        if self._jit is not None:
            return float(self._jit.route_energy(dr.arrays, stops, dr.k.limits))
        load = dr.cand_w[stops][::-1].cumsum()[::-1]
        prev = np.empty_like(stops)
        prev[0], prev[1:] = dr.cand.size, stops[:-1]  # the start is the last column
        legs = dr.dmat[stops, prev]
        legs_j = (legs * dr.k.e(np.minimum(load, dr.k.cap))).cumsum()
        return float(legs_j[-1]) + float(dr.cand_end[dr.stops[-1]])

    def _record(
        self, pool: list[dict[tuple[int, ...], float]], users: list[int] | None = None
    ) -> None:
        for u in range(len(self.drones)) if users is None else users:
            dr = self.drones[u]
            key = tuple(int(dr.cand[j]) for j in dr.stops)
            if key and key not in pool[u]:
                pool[u][key] = dr.energy

    def _ruin_route(
        self, busy: list[int], users: list[int], rng: np.random.Generator, free: NDArray[np.bool_]
    ) -> list[int]:
        """Remove one to three stops of one route; another drone that could serve what
        was freed is refilled too (a relocation). Returns the drones to refill."""
        u = busy[int(rng.integers(len(busy)))]
        dr = self.drones[u]
        n_drop = int(rng.integers(1, min(3, len(dr.stops)) + 1))
        drop = sorted(rng.choice(len(dr.stops), n_drop, replace=False).tolist())
        freed = dr.cand[[dr.stops[j] for j in drop]]
        free[freed] = True
        self._remove(u, drop)
        return [u, *self._relocation(freed, [u], users, rng, fallback=True)]

    def _relocation(
        self,
        freed: NDArray[np.int64] | list[int],
        ruined: list[int],
        users: list[int],
        rng: np.random.Generator,
        fallback: bool = False,
    ) -> list[int]:
        """A random drone besides the ``ruined`` ones that could serve a freed request
        (with ``fallback``, any other drone when none could), to refill as well."""
        could: NDArray[np.bool_] = np.asarray(self._can[:, freed].any(axis=1))
        others = [v for v in users if could[v] and v not in ruined]
        if not others and fallback:
            others = [v for v in users if v not in ruined]
        return [others[int(rng.integers(len(others)))]] if others else []

    def _ruin_near(
        self, busy: list[int], users: list[int], rng: np.random.Generator, free: NDArray[np.bool_]
    ) -> list[int]:
        """Remove 2 to ``_RUIN_MAX`` served stops nearest a random served one, from at most
        three routes, so that neighbouring routes can trade stops; a drone that could
        serve what was freed is refilled too. Returns the drones to refill."""
        stops = self._served(busy)
        by_req = np.argsort(stops[0])  # served requests by position (each served once)
        served = stops[0][by_req]
        centre = self.xy[served[int(rng.integers(served.size))]]
        n_drop = int(rng.integers(2, _RUIN_MAX + 1))
        near = by_req[np.argsort(np.hypot(*(self.xy[served] - centre).T), kind="stable")]
        return self._drop_first(near, stops, n_drop, free, users, rng)

    def _served(
        self, busy: list[int]
    ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
        """Every served stop of the ``busy`` drones, route by route: its request, drone and
        index in the route."""
        stops = [self.drones[u].stops for u in busy]
        reqs = np.concatenate([self.drones[u].cand[st] for u, st in zip(busy, stops, strict=True)])
        who = np.repeat(np.asarray(busy, dtype=np.int64), [len(st) for st in stops])
        pos = np.concatenate([np.arange(len(st), dtype=np.int64) for st in stops])
        return reqs, who, pos

    def _drop_first(
        self,
        ranked: NDArray[np.int64],
        served: tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]],
        n_drop: int,
        free: NDArray[np.bool_],
        users: list[int],
        rng: np.random.Generator,
    ) -> list[int]:
        """Remove the first ``n_drop`` served stops in ``ranked`` order (indices into
        the arrays of :meth:`_served`, given as ``served``) from at most three routes
        (:meth:`_drop`)."""
        reqs, who, pos = served
        drops: dict[int, list[int]] = {}
        freed: list[int] = []
        for r in ranked.tolist():
            u = int(who[r])
            if u not in drops and len(drops) == 3:
                continue
            drops.setdefault(u, []).append(int(pos[r]))
            freed.append(int(reqs[r]))
            if len(freed) == n_drop:
                break
        return self._drop(drops, freed, free, users, rng)

    def _without(self, dr: _Drone) -> NDArray[np.float64]:
        """Exact energy of the route without each of its stops (in route order; the
        legs' energies added in route order, as the compiled one adds them)."""
        stops = np.array(dr.stops, dtype=np.int64)
        k = stops.size
        if self._jit is not None:
            out = np.empty(k)
            self._jit.without(dr.arrays, stops, dr.k.limits, out)
            return out
        w = dr.cand_w[stops]
        load = np.minimum(w[::-1].cumsum()[::-1], dr.k.cap)  # on the leg into each stop
        prev = np.empty_like(stops)
        prev[0], prev[1:] = dr.cand.size, stops[:-1]
        legs = dr.dmat[stops, prev]
        base = legs * dr.k.e(load)
        # Legs before the removed stop i carry its parcel no more.
        lighter = legs[None, :] * dr.k.e(np.maximum(load[None, :] - w[:, None], 0.0))
        out = (lighter * np.tri(k, k, -1)).cumsum(axis=1)[:, -1]
        after = np.concatenate([base[::-1].cumsum()[::-1], [0.0]])  # legs l..k-1
        out[:-1] += dr.dmat[stops[1:], prev[:-1]] * dr.k.e(load[1:])  # prev(i) -> stop i + 1
        out[:-2] += after[2:-1]
        out[:-1] += dr.cand_end[stops[-1]]
        out[-1] += dr.cand_end[stops[-2]] if k > 1 else dr.start_end
        return out

    def _drop(
        self,
        drops: dict[int, list[int]],
        freed: list[int],
        free: NDArray[np.bool_],
        users: list[int],
        rng: np.random.Generator,
    ) -> list[int]:
        """Remove the stops ``drops`` names (route positions per drone), whose requests are
        ``freed``; returns the ruined drones and those a relocation adds, to refill."""
        free[freed] = True
        for u, idx in drops.items():
            self._remove(u, sorted(idx))
        ruined = sorted(drops)
        return ruined + self._relocation(freed, ruined, users, rng)

    def _ruin_worst(
        self, busy: list[int], users: list[int], rng: np.random.Generator, free: NDArray[np.bool_]
    ) -> list[int]:
        """Remove the 2 to ``_RUIN_MAX`` served stops whose detour costs the most energy
        (with noise), from at most three routes; a drone that could serve what was
        freed is refilled too. Returns the drones to refill."""
        saving = []
        for u in busy:
            dr = self.drones[u]
            key = (u, tuple(dr.stops))
            without = self._without_j.get(key)
            if without is None:  # most routes are met again: keep what they cost
                without = self._without_j[key] = self._without(dr)
            saving.append(dr.energy - without)
        served = self._served(busy)
        cost = np.concatenate(saving)
        noisy = cost * rng.uniform(_NOISE, 1.0, cost.size)
        n_drop = int(rng.integers(2, _RUIN_MAX + 1))
        ranked = np.argsort(-noisy, kind="stable")
        return self._drop_first(ranked, served, n_drop, free, users, rng)

    def _exchange(self, users: list[int], free: NDArray[np.bool_], kind: str) -> None:
        """Swap a served stop for an unserved candidate while a route's G grows
        (then top the route up); every route met is recorded by the caller."""
        for u in users:
            dr = self.drones[u]
            for _ in range(2 * len(dr.stops) + 2):
                if not dr.stops:
                    break
                g0 = float(self.prize[dr.cand[dr.stops]].sum()) - dr.energy
                stops, energy, weight = dr.stops, dr.energy, dr.weight
                best_d, best = 1e-6, None
                for pos in range(len(stops)):
                    dr.stops = stops[:pos] + stops[pos + 1 :]
                    e_wo = self._route_energy(dr)
                    w_wo = weight - float(dr.cand_w[stops[pos]])
                    sub = np.flatnonzero(free[dr.cand] & (w_wo + dr.cand_w <= dr.k.fit_kg))
                    if not sub.size:
                        continue
                    d_e, slot = self._insertion(dr, sub)
                    gain = self.prize[dr.cand[sub]] - d_e
                    feas = e_wo + d_e <= dr.k.usable
                    if not feas.any():
                        continue
                    g_wo = float(self.prize[dr.cand[dr.stops]].sum()) - e_wo
                    cand_g = np.where(feas, gain, -np.inf)
                    j = int(cand_g.argmax())
                    d = g_wo + float(cand_g[j]) - g0
                    if d > best_d:
                        best_d, best = d, (pos, int(sub[j]), int(slot[j]), e_wo + float(d_e[j]))
                dr.stops, dr.energy, dr.weight = stops, energy, weight
                if best is None:
                    break
                pos, j, at, e_new = best
                old = dr.stops[pos]
                new_stops = dr.stops[:pos] + dr.stops[pos + 1 :]
                new_stops.insert(at, j)
                dr.stops, dr.energy, dr.psum = new_stops, e_new, None
                dr.weight = weight - float(dr.cand_w[old]) + float(dr.cand_w[j])
                free[dr.cand[old]] = True
                free[dr.cand[j]] = False
                self._fill([u], kind, free)

    def build(self, iterations: int = 80, seed: int = 0) -> PoolResult:
        """Constructions with every score, exchanges in the best, ``iterations``
        ruin-and-recreate steps, then exchanges in the best solution found."""
        n_u = len(self.drones)
        pool: list[dict[tuple[int, ...], float]] = [{} for _ in range(n_u)]
        users = [u for u in range(n_u) if self.drones[u].cand.size]
        best_g, best_snap, best_kind = -np.inf, self._snapshot(), SCORES[0]
        for kind in SCORES:
            free = self._reset()
            self._fill(users, kind, free)
            self._record(pool)
            g = self._g()
            if g > best_g + 1e-9:
                best_g, best_snap, best_kind = g, self._snapshot(), kind
        if users:  # the best construction's routes, improved by exchanges
            free = self._restore(best_snap)
            self._exchange(users, free, best_kind)
            self._record(pool)
            g = self._g()
            if g > best_g + 1e-9:
                best_g, best_snap = g, self._snapshot()
        # Ruin and recreate from the best so far; a worse result is accepted while it is
        # within a threshold that falls to zero (it lets the search leave a local optimum).
        rng = np.random.default_rng(seed)
        current, cur_g = best_snap, best_g
        free = self._restore(current)
        dirty: list[int] = []  # drones whose route differs from ``current``
        for it in range(iterations if users else 0):
            self._restore_some(current, dirty, free)
            busy = [u for u in users if self.drones[u].stops]
            if not busy:
                break
            if it % 3 == 2:
                touched = self._ruin_worst(busy, users, rng, free)
            elif it % 2:
                touched = self._ruin_near(busy, users, rng, free)
            else:
                touched = self._ruin_route(busy, users, rng, free)
            kind = SCORES[it % len(SCORES)] if it % 4 == 3 else best_kind
            self._fill(touched, kind, free, rng)
            self._record(pool, touched)
            g = self._g()
            accept = g > best_g + 1e-9
            if accept:
                best_g, best_snap = g, self._snapshot()
            if accept or g > cur_g - _ACCEPT * abs(best_g) * (1 - it / iterations):
                current, cur_g, dirty = list(current), g, []
                for u in touched:
                    current[u] = self._state(u)
            else:
                dirty = touched
        if users:  # the best solution's routes, improved by exchanges
            free = self._restore(best_snap)
            self._exchange(users, free, best_kind)
            self._record(pool)
            best_g = max(best_g, self._g())
        routes = [list(p.keys()) for p in pool]
        energy = [list(p.values()) for p in pool]
        return PoolResult(routes, energy, float(best_g))


def build_pool(
    problem: WindowProblem, *, n_candidates: int = 80, iterations: int = 80, seed: int = 0
) -> PoolResult:
    """The route pool of one window (module docstring), built for ``problem.search``."""
    return RoutePool(problem, n_candidates).build(iterations, seed)


def finish_route(
    start_xy: NDArray[np.float64],
    end_xy: NDArray[np.float64] | None,
    depots_xy: NDArray[np.float64],
    stops_xy: NDArray[np.float64],
    weights: NDArray[np.float64],
    model: EnergyModel,
) -> tuple[NDArray[np.int64], int]:
    """The energy-minimal visiting order of a route and its end depot.

    ``end_xy`` None lands at the depot nearest the last customer (the order and the
    landing are optimised together). Exact (subset dynamic program) up to
    ``_EXACT_MAX`` stops; longer routes keep their order. Returns (order, end depot
    index into ``depots_xy``, or -1 when ``end_xy`` was given).
    """
    n = weights.size
    if n == 0:
        return np.zeros(0, dtype=np.int64), -1
    if 1 < n <= min(_EXACT_MAX, MAX_STOPS):
        d = node_distances(start_xy, start_xy if end_xy is None else end_xy, stops_xy)
        if end_xy is None:
            d[:n, n + 1] = nearest_depot(stops_xy, depots_xy)[1]
        bits, _ = subset_masks(n)
        total = bits @ weights
        cap = model.max_payload_kg
        e_mask = model.energy_per_m(np.minimum(total, cap))
        order_all = exact_orders(d, e_mask, float(model.energy_per_m(0.0)), n)
        order = order_all[-1].astype(np.int64)
        # Never worse than the given order (the table is exact, this guards rounding).
        full = np.array([[*order], [*range(n)]], dtype=np.int8)
        _, e = evaluate_orders(full, d, weights, np.full(2, total[-1]), model, n)
        if e[1] < e[0]:
            order = np.arange(n)
    else:
        order = np.arange(n)
    end = int(nearest_depot(stops_xy[order[-1]], depots_xy)[0][0]) if end_xy is None else -1
    return order, end
