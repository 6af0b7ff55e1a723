"""The route pool's construction (docs/method.md §4.4, steps 2 and 3): greedy parallel
insertion, the seeded routes of drones left empty, and the exchange of a served stop
for a better unserved candidate.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .pool_pricing import PoolPricing
from .pool_state import Drone, Route, best_of

__all__ = ["PoolConstruction"]
_SEED_TRIES = 3  # an opening route tries this many seeds (:meth:`PoolConstruction._seed`)
_SEED_NEAR = 8  # a seed is rated with this many of its best neighbours


class PoolConstruction(PoolPricing):
    """Routes built and improved by insertion and exchange (module docstring)."""

    def _fill(
        self,
        users: list[int],
        score_kind: str,
        free: NDArray[np.bool_],
        rng: np.random.Generator | None = None,
        seed: bool = True,
    ) -> None:
        """Greedy insertion into the routes of ``users`` until nothing profitable fits
        (scores blurred with ``rng``, :meth:`_refresh`); then each drone that started
        empty, some of whose candidates do not pay alone, tries seeded routes against
        the one insertion opened (:meth:`_seed`; not with ``seed`` False)."""
        drones = self.drones
        opened = [u for u in users if drones[u].seedable and not drones[u].stops] if seed else []
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
                            best[i2], at[i2] = best_of(d2.score)
        for u in opened:
            self._seed(u, score_kind, free, rng)

    def _seed(
        self,
        u: int,
        score_kind: str,
        free: NDArray[np.bool_],
        rng: np.random.Generator | None,
    ) -> None:
        """Open drone ``u``'s route at a request that need not pay alone.

        Greedy insertion opens a route with the request that pays best alone, or with
        none where none pays (a high α prices delay low), although a cluster of requests
        that do not pay alone may pay together, and better than the route the greedy
        opening leads to (a heavy parcel that barely pays fills the payload). Each free
        candidate is rated by its gain alone plus what its ``_SEED_NEAR`` best
        neighbours that share the payload with it would add (prize less a there-and-back
        detour); the ``_SEED_TRIES`` best with a positive rating each start a route that
        is then filled greedily, and the route of highest G, the one already there
        included, is kept if its G is positive (else the route stays empty)."""
        dr = self.drones[u]
        best: tuple[float, Route] | None = None
        if dr.stops:  # the route the greedy opening built competes with the seeds
            best = (self._opened_g(dr), self._state(u))
            self._clear(dr, free)
        sub = (free[dr.cand] & (dr.cand_w <= dr.k.fit_kg)).nonzero()[0]
        d_e, _ = self._insertion(dr, sub)
        gain = dr.cand_prize[sub] - d_e
        add = dr.cand_prize[sub][None, :] - dr.pair_j[np.ix_(sub, sub)]
        np.fill_diagonal(add, 0.0)
        add = np.maximum(add, 0.0)
        if add.shape[1] > _SEED_NEAR:
            add = np.partition(add, add.shape[1] - _SEED_NEAR, axis=1)[:, -_SEED_NEAR:]
        rating = gain + add.sum(axis=1)
        order = np.lexsort((sub, -rating))[:_SEED_TRIES]
        for i in order[rating[order] > 0].tolist():
            j = int(sub[i])
            dr.slot[j], dr.d_e[j] = 0, d_e[i]
            self._insert(u, j)
            free[dr.cand[j]] = False
            self._fill([u], score_kind, free, rng, seed=False)
            g = self._opened_g(dr)
            if g > 1e-9 and (best is None or g > best[0] + 1e-9):
                best = (g, self._state(u))
            self._clear(dr, free)
        if best is not None:
            self._put(dr, best[1], free)

    def _opened_g(self, dr: Drone) -> float:
        """G the drone's route adds to its empty flight: prizes less the extra energy."""
        return self._psum(dr) - (dr.energy - dr.start_end)

    @staticmethod
    def _clear(dr: Drone, free: NDArray[np.bool_]) -> None:
        """Empty ``dr``'s route, its requests free again."""
        free[dr.cand[dr.stops]] = True
        dr.stops, dr.energy, dr.weight, dr.psum = [], dr.start_end, 0.0, None

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
