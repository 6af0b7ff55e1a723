"""The route pool's state (docs/method.md §4.4): each drone's candidates and its route
under construction, and the solutions the search keeps.

:class:`PoolState` chooses each drone's candidates (step 1) and holds every drone's
route; a solution is every drone's route (a :data:`Route` each), kept and put back as
the search goes. The pricing of its routes is :mod:`.pool_pricing`'s; :mod:`.pool`
builds the pool.
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
from .problem import DroneTask, WindowProblem

__all__ = ["Drone", "Kind", "PoolState", "Route", "best_of"]
Route = tuple[tuple[int, ...], float, float, float]  # stops, energy, weight, prizes
# np.interp's compiled core: the same values without the wrapper's checks, which cost as
# much as the interpolation itself on the search's small arrays.
_interp = getattr(np, "_core", np).multiarray.interp


def best_of(score: NDArray[np.float64]) -> tuple[float, int]:
    """The highest score and its index (the first of equals); (−inf, 0) when empty."""
    if not score.size:
        return -np.inf, 0
    j = int(score.argmax())
    return float(score[j]), j


def pack_priced(
    energy_j: NDArray[np.float64] | float,
    metres: NDArray[np.float64] | float,
    model: EnergyModel,
    pack: float,
) -> NDArray[np.float64] | float:
    """What the route pool prices loaded flight at (``[plan] pack_price``, docs/method.md
    §4.4 step 8): ``pack`` of the way from its exact energy ``energy_j`` to the full
    payload's energy over its ``metres``."""
    full = float(model.energy_per_m(model.max_payload_kg))
    return (1.0 - pack) * energy_j + pack * full * metres


@dataclass(frozen=True)
class Kind:
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
    def of(cls, model: EnergyModel, pack: float = 0.0) -> Kind:
        """The type of ``model``; ``pack`` > 0 prices each loaded leg that share of the way
        to the full payload's energy per metre (``[plan] pack_price``)."""
        table = np.asarray(model.table_j_per_m, dtype=np.float64)
        if pack > 0:  # per metre
            table = np.asarray(pack_priced(table, 1.0, model, pack), dtype=np.float64)
        return cls(
            model,
            model.max_payload_kg,
            model.usable_j - ENERGY_TOL_J,
            float(model.energy_per_m(0.0)),
            model.max_payload_kg + PAYLOAD_TOL_KG,
            model.grid_kg,
            table,
        )

    def e(self, load: NDArray[np.float64] | float) -> NDArray[np.float64]:
        """Energy per metre with ``load`` kg on board (the model's own table, unchecked)."""
        return _interp(load, self.grid, self.table)

    @cached_property
    def limits(self) -> tuple[float, float, float, NDArray[np.float64], NDArray[np.float64]]:
        """What the compiled kernels read of the type (:data:`._jit.Limits`)."""
        return (self.cap, self.fit_kg, self.usable, self.grid, self.table)


@dataclass
class Drone:
    """A drone's candidates and its route under construction."""

    k: Kind
    start_xy: NDArray[np.float64]
    cand: NDArray[np.int64]  # positions
    cand_xy: NDArray[np.float64]
    cand_w: NDArray[np.float64]
    cand_prize: NDArray[np.float64]
    dmat: NDArray[np.float64]  # (m, m + 1) distances candidate -> candidate, or -> start
    cand_end: NDArray[np.float64]  # energy of the empty last leg from each candidate
    start_end: float  # ... and from the start (the empty route)
    seedable: bool = False  # some candidate does not pay alone: an opening tries seeds
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
    def pair_j(self) -> NDArray[np.float64]:
        """``(m, m)`` the there-and-back detour from candidate i to candidate j carrying
        both parcels (capped at the payload), J; +inf where the two exceed the payload
        together (a seed's neighbours, :meth:`PoolConstruction._seed`)."""
        m = self.cand.size
        both = self.cand_w[:, None] + self.cand_w[None, :]
        out = 2.0 * self.dmat[:, :m] * self.k.e(np.minimum(both, self.k.cap))
        out[both > self.k.fit_kg] = np.inf
        return out

    @cached_property
    def best(self) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
        """The cached best insertions, filled in place (:data:`._jit.Best`)."""
        return (self.score, self.slot, self.d_e)


class PoolState:
    """Each drone's candidates and route, and the pool's solutions (module docstring)."""

    def __init__(self, problem: WindowProblem, n_candidates: int = 80, pack: float = 0.0) -> None:
        """The pool of ``problem``'s drones, built for the prizes ``problem.search``;
        each drone keeps its ``n_candidates`` best requests (and those it is home to)."""
        tasks = list(problem.tasks)
        kinds: dict[int, Kind] = {}  # one per energy model (drone type)
        self.kinds = [kinds.setdefault(id(t.model), Kind.of(t.model, pack)) for t in tasks]
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
        self, task: DroneTask, k: Kind
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
        k: Kind,
        scored: tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]],
        home: NDArray[np.int64],
        u: int,
        n_candidates: int,
    ) -> Drone:
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
        return Drone(
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

    # -- solutions -----------------------------------------------------------------------

    def _reset(self) -> NDArray[np.bool_]:
        for dr in self.drones:
            dr.stops, dr.energy, dr.weight, dr.psum = [], dr.start_end, 0.0, None
        return np.ones(self.w.size, dtype=bool)

    def _psum(self, dr: Drone) -> float:
        if dr.psum is None:
            dr.psum = float(dr.cand_prize[dr.stops].sum())
        return dr.psum

    def _g(self) -> float:
        """G of the current routes: prizes served less every drone's energy."""
        return float(sum(self._psum(dr) - dr.energy for dr in self.drones))

    def _state(self, u: int) -> Route:
        dr = self.drones[u]
        return (tuple(dr.stops), dr.energy, dr.weight, self._psum(dr))

    def _snapshot(self) -> list[Route]:
        return [self._state(u) for u in range(len(self.drones))]

    def _restore(self, snap: list[Route]) -> NDArray[np.bool_]:
        free = np.ones(self.w.size, dtype=bool)
        for dr, route in zip(self.drones, snap, strict=True):
            self._put(dr, route, free)
        return free

    def _restore_some(self, snap: list[Route], users: list[int], free: NDArray[np.bool_]) -> None:
        """Put the routes of ``users`` back as in ``snap`` (the others are as there)."""
        for u in users:
            dr = self.drones[u]
            free[dr.cand[dr.stops]] = True
        for u in users:
            self._put(self.drones[u], snap[u], free)

    @staticmethod
    def _put(dr: Drone, route: Route, free: NDArray[np.bool_]) -> None:
        """Give ``dr`` the route ``route`` (its requests taken; ``dr``'s own were freed)."""
        stops, dr.energy, dr.weight, dr.psum = route
        dr.stops = list(stops)
        free[dr.cand[dr.stops]] = False

    def _record(
        self, pool: list[dict[tuple[int, ...], float]], users: list[int] | None = None
    ) -> None:
        for u in range(len(self.drones)) if users is None else users:
            dr = self.drones[u]
            key = tuple(int(dr.cand[j]) for j in dr.stops)
            if key and key not in pool[u]:
                pool[u][key] = dr.energy
