"""The route pool's ruins (docs/method.md §4.4, step 4): the three ways ruin and
recreate frees stops (a few stops of one route, with a relocation; the served stops
nearest a random one; the stops whose detour costs the most energy) before the touched
routes are refilled (:mod:`.pool_construct`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .pool_pricing import PoolPricing

__all__ = ["PoolRuins"]
_RUIN_MAX = 8  # the nearest-stops and worst-detour ruins free 2 to this many stops
_NOISE = 0.5  # the worst-detour ruin ranks each stop's saving times U(_NOISE, 1)


class PoolRuins(PoolPricing):
    """The ruins of ruin and recreate (module docstring)."""

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
