"""The route pool's pricing (docs/method.md §4.4): the exact, payload-aware energy of a
route, of inserting a candidate into it and of removing each of its stops, and each
candidate's best insertion and score.

Each price has its numpy expression here and the compiled kernel of :mod:`._jit` that
gives the same floats (loaded by :func:`.kernels.kernels`): the numpy code is the
reference the kernels are tested against, and what runs where numba is missing.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .pool_state import Drone, PoolState, best_of

__all__ = ["PoolPricing"]
_BLINK = 0.5  # ruin and recreate refills by each insertion's score times U(1 - _BLINK, 1)
_NO_BLUR = np.zeros(0)  # the compiled refresh's "scores not blurred"


class PoolPricing(PoolState):
    """The pool's routes priced exactly (module docstring)."""

    def _insertion(
        self, dr: Drone, sub: NDArray[np.int64]
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
        return best_of(dr.score)

    def _insert(self, u: int, j: int) -> None:
        dr = self.drones[u]
        dr.stops.insert(int(dr.slot[j]), j)
        dr.psum = None
        dr.energy += float(dr.d_e[j])
        dr.weight += float(self.w[dr.cand[j]])

    def _remove(self, u: int, drop: list[int]) -> None:
        """Remove stops (indices into the route) and recompute energy exactly."""
        dr = self.drones[u]
        gone = set(drop)
        dr.stops = [j for i, j in enumerate(dr.stops) if i not in gone]
        dr.psum = None
        dr.energy = self._route_energy(dr)
        dr.weight = float(self.w[dr.cand[dr.stops]].sum())

    def _route_energy(self, dr: Drone) -> float:
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

    def _without(self, dr: Drone) -> NDArray[np.float64]:
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
