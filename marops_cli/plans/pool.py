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

:class:`RoutePool` is one class over five modules: the drones' candidates, routes and
solutions (:mod:`.pool_state`); their exact pricing on top (:mod:`.pool_pricing`); on
that, construction, seeds and exchange (:mod:`.pool_construct`) and the ruins of ruin and
recreate (:mod:`.pool_ruins`); here, the search that uses them all
(:meth:`RoutePool.build`) and the finish of a chosen route (:func:`finish_route`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..energy import EnergyModel
from ..segment.depots import nearest_depot
from .order import MAX_STOPS, evaluate_orders, exact_orders, node_distances, subset_masks
from .pool_construct import PoolConstruction
from .pool_ruins import PoolRuins
from .problem import DroneTask, WindowProblem

__all__ = ["DroneTask", "PoolResult", "RoutePool", "build_pool", "finish_route"]
SCORES = ("weight", "density", "gain")
_ACCEPT = 0.01  # ruin and recreate accepts a solution up to this share of G worse, falling to 0
_EXACT_MAX = 10  # exact re-ordering up to this many stops (2**10 subsets)


@dataclass(frozen=True)
class PoolResult:
    """Each drone's distinct routes (positions in insertion order) with their energy."""

    routes: list[list[tuple[int, ...]]]
    energy_j: list[list[float]]
    best_g: float
    """G of the best single conflict-free solution found (the selection does at least as well)."""


class RoutePool(PoolConstruction, PoolRuins):
    """Builds the route pool of one window (module docstring)."""

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
    problem: WindowProblem,
    *,
    n_candidates: int = 80,
    iterations: int = 80,
    seed: int = 0,
    pack: float = 0.0,
) -> PoolResult:
    """The route pool of one window (module docstring), built for ``problem.search``."""
    return RoutePool(problem, n_candidates, pack).build(iterations, seed)


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
