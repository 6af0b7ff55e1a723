"""numba kernels of the route pool (loaded through :func:`.kernels.kernels`).

Each mirrors a numpy expression of :class:`.pool_pricing.PoolPricing` operation by
operation, so that both give the same floats: no fast-math, no reordered sums. The energy per metre
is ``np.interp`` on the energy model's uniform load grid, done as numpy does it (the
interval found, then slope × offset + value).

What travels together is one tuple (numba takes tuples of arrays as they are):

* ``drone`` (:data:`Drone`): a drone's candidates as :class:`.pool_state.Drone` holds
  them: the distances ``dmat`` (candidate -> candidate, the start the last column), the
  parcel weights ``cand_w``, the empty last leg's energy from each ``cand_end``, the
  empty route's ``start_end``, the candidates' positions ``cand`` and prizes
  ``cand_prize``;
* ``limits`` (:data:`Limits`): its type's payload ``cap``, heaviest load ``fit_kg``,
  battery ``usable`` and energy per metre (``grid`` kg -> ``table`` J/m);
* ``route`` (:data:`Route`): the route's ``stops``, its ``weight`` and ``energy``;
* ``best`` (:data:`Best`): each candidate's best insertion, as the pool caches it (its
  ``score``, ``slot`` and extra energy ``d_e``).
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numpy.typing import NDArray

__all__ = [
    "KIND",
    "Best",
    "Drone",
    "Limits",
    "Route",
    "insertion",
    "refresh",
    "route_energy",
    "warm_up",
    "without",
]

KIND = {"density": 0, "weight": 1, "gain": 2}
"""The construction scores (:data:`.pool.SCORES`) as the kernels number them."""

_F = NDArray[np.float64]
_I = NDArray[np.int64]
Drone = tuple[_F, _F, _F, float, _I, _F]
"""dmat, cand_w, cand_end, start_end, cand, cand_prize (module docstring)."""
Limits = tuple[float, float, float, _F, _F]
"""cap, fit_kg, usable, grid, table (module docstring)."""
Route = tuple[_I, float, float]
"""stops, weight, energy (module docstring)."""
Best = tuple[_F, _I, _F]
"""score, slot, d_e (module docstring)."""


@nb.njit(cache=True, nogil=True)
def _interp(x: float, xp: NDArray[np.float64], fp: NDArray[np.float64]) -> float:
    """``np.interp(x, xp, fp)`` for an increasing, evenly spaced ``xp``."""
    n = xp.size
    if x >= xp[n - 1]:
        return fp[n - 1]
    if x <= xp[0]:
        return fp[0]
    j = min(int((x - xp[0]) / ((xp[n - 1] - xp[0]) / (n - 1))), n - 2)
    while j > 0 and xp[j] > x:  # the division may land one interval off
        j -= 1
    while j < n - 2 and xp[j + 1] <= x:
        j += 1
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    return slope * (x - xp[j]) + fp[j]


@nb.njit(cache=True, nogil=True)
def _loads(cand_w: NDArray[np.float64], stops: NDArray[np.int64], out: NDArray[np.float64]) -> None:
    """The load on the leg into each stop (the weights still to deliver), into the first
    ``stops.size`` cells of ``out``: numpy's reversed cumulative sum, added alike."""
    acc = 0.0
    for i in range(stops.size - 1, -1, -1):
        acc = acc + cand_w[stops[i]]
        out[i] = acc


@nb.njit(cache=True, nogil=True)
def insertion(
    drone: Drone,
    stops: NDArray[np.int64],
    sub: NDArray[np.int64],
    limits: Limits,
    out: tuple[NDArray[np.float64], NDArray[np.int64]],
) -> None:
    """:meth:`.pool_pricing.PoolPricing._insertion`: the least extra energy of inserting
    each candidate of ``sub`` into the route ``stops`` (into ``out[0]``) and where (the
    slot, into ``out[1]``), both indexed like ``sub``."""
    dmat, cand_w, cand_end, start_end = drone[0], drone[1], drone[2], drone[3]
    cap, grid, table = limits[0], limits[3], limits[4]
    d_out, slot_out = out
    k = stops.size
    start = dmat.shape[0]  # the start is the last column
    load = np.zeros(k + 1)  # leaving node i (the start is node 0)
    e_l = np.empty(k + 1)
    legs = np.empty(k)  # node i -> node i + 1
    _loads(cand_w, stops, load)
    prev = start
    for i in range(k):
        e_l[i] = _interp(load[i], grid, table)
        legs[i] = dmat[stops[i], prev]
        prev = stops[i]
    e_l[k] = _interp(load[k], grid, table)
    d = np.empty(k + 1)
    e_q = np.empty(k + 1)
    d_q = np.empty(k + 1)
    for n in range(sub.size):
        q = sub[n]
        if k == 0:  # start -> q with its parcel -> end empty
            e = dmat[q, start] * _interp(min(cand_w[q], cap), grid, table)
            d_out[n] = e + cand_end[q] - start_end
            slot_out[n] = 0
            continue
        prev = start
        for i in range(k + 1):
            d_q[i] = dmat[q, prev]
            if i < k:
                prev = stops[i]
            e_q[i] = _interp(min(load[i] + cand_w[q], cap), grid, table)
            d[i] = d_q[i] * e_q[i]
        acc = 0.0  # the legs before the new stop carry its parcel too
        for i in range(k):
            acc = acc + (e_q[i] - e_l[i]) * legs[i]
            d[i + 1] = d[i + 1] + acc
        for i in range(k):  # node i -> q -> node i + 1 replaces node i -> node i + 1
            d[i] = d[i] + (d_q[i + 1] * e_l[i] - legs[i] * e_l[i])
        d[k] = d[k] + (cand_end[q] - cand_end[stops[k - 1]])
        at = 0
        for i in range(1, k + 1):
            if d[i] < d[at]:
                at = i
        d_out[n] = d[at]
        slot_out[n] = at


@nb.njit(cache=True, nogil=True)
def route_energy(drone: Drone, stops: NDArray[np.int64], limits: Limits) -> float:
    """:meth:`.pool_pricing.PoolPricing._route_energy` of a route of at least one stop:
    each leg's length times the energy per metre of its load, summed in route order, plus
    the empty last leg."""
    dmat, cand_w, cand_end = drone[0], drone[1], drone[2]
    cap, grid, table = limits[0], limits[3], limits[4]
    k = stops.size
    load = np.empty(k)
    _loads(cand_w, stops, load)
    total = 0.0
    prev = dmat.shape[0]  # the start is the last column
    for i in range(k):
        leg = dmat[stops[i], prev] * _interp(min(load[i], cap), grid, table)
        total = leg if i == 0 else total + leg
        prev = stops[i]
    return total + cand_end[stops[k - 1]]


@nb.njit(cache=True, nogil=True)
def without(
    drone: Drone, stops: NDArray[np.int64], limits: Limits, out: NDArray[np.float64]
) -> None:
    """:meth:`.pool_pricing.PoolPricing._without`: the route's energy without each of its
    stops (into ``out``, in route order)."""
    dmat, cand_w, cand_end, start_end = drone[0], drone[1], drone[2], drone[3]
    cap, grid, table = limits[0], limits[3], limits[4]
    k = stops.size
    start = dmat.shape[0]
    load = np.empty(k)  # on the leg into each stop
    _loads(cand_w, stops, load)
    for i in range(k):
        load[i] = min(load[i], cap)
    legs = np.empty(k)
    prev = np.empty(k, dtype=np.int64)
    for i in range(k):
        prev[i] = start if i == 0 else stops[i - 1]
        legs[i] = dmat[stops[i], prev[i]]
    after = np.zeros(k + 1)  # legs l..k-1 at their loads
    for i in range(k - 1, -1, -1):
        base = legs[i] * _interp(load[i], grid, table)
        after[i] = base if i == k - 1 else after[i + 1] + base
    for i in range(k):
        acc = 0.0  # the legs before stop i, lighter by its parcel
        for j in range(i):
            lighter = legs[j] * _interp(max(load[j] - cand_w[stops[i]], 0.0), grid, table)
            acc = lighter if j == 0 else acc + lighter
        if i < k - 1:
            acc = acc + dmat[stops[i + 1], prev[i]] * _interp(load[i + 1], grid, table)
        if i < k - 2:
            acc = acc + after[i + 2]
        if i < k - 1:
            acc = acc + cand_end[stops[k - 1]]
        else:
            acc = acc + (cand_end[stops[k - 2]] if k > 1 else start_end)
        out[i] = acc


@nb.njit(cache=True, nogil=True)
def refresh(
    drone: Drone,
    limits: Limits,
    route: Route,
    free: NDArray[np.bool_],
    best: Best,
    scoring: tuple[int, NDArray[np.float64]],
) -> tuple[float, int]:
    """:meth:`.pool_pricing.PoolPricing._refresh`: every score to −inf, then each candidate
    that is ``free`` and still fits the payload (the route's weight + its own ≤
    ``fit_kg``): its best insertion, extra energy and score (``scoring``: the score's
    number in :data:`KIND`, and a blur factor per candidate, the score times it when it
    is not empty), into ``best``. Returns the best score and its candidate (the first of
    equals; (−inf, 0) when none)."""
    cand_w, cand, cand_prize = drone[1], drone[4], drone[5]
    cap, fit_kg, usable = limits[0], limits[1], limits[2]
    stops, weight, energy = route
    score, slot, d_e = best
    kind, blur = scoring
    score[:] = -np.inf
    sub = np.empty(cand.size, dtype=np.int64)  # the free candidates that still fit
    m = 0
    for q in range(cand.size):
        if free[cand[q]] and weight + cand_w[q] <= fit_kg:
            sub[m] = q
            m += 1
    sub = sub[:m]
    d_sub = np.empty(m)
    slot_sub = np.empty(m, dtype=np.int64)
    insertion(drone, stops, sub, limits, (d_sub, slot_sub))
    for n in range(m):
        q = sub[n]
        de = d_sub[n]
        gain = cand_prize[q] - de
        if kind == 0:
            s = gain / max(cand_w[q] / cap + max(de, 0.0) / usable, 1e-9)
        elif kind == 1:
            s = gain / max(cand_w[q], 1e-9)
        else:
            s = gain
        if blur.size:
            s = s * blur[q]
        score[q] = s if energy + de <= usable and gain > 0 else -np.inf
        slot[q] = slot_sub[n]
        d_e[q] = de
    top, at = -np.inf, 0
    for q in range(score.size):
        if score[q] > top:
            top, at = score[q], q
    return top, at


def warm_up() -> None:
    """Compile (or load from the cache) every kernel on a two-stop route, so that a
    failure shows here, once, rather than in the middle of a plan."""
    grid = np.linspace(0.0, 2.0, 5)
    table = 1.0 + grid**2
    dmat = np.array([[0.0, 3.0, 1.0], [3.0, 0.0, 2.0]])
    w, end = np.array([0.5, 0.7]), np.array([1.0, 2.0])
    stops = np.array([0], dtype=np.int64)
    drone = (dmat, w, end, 1.0, np.arange(2), np.full(2, 50.0))
    limits = (2.0, 2.0, 100.0, grid, table)
    best = (np.zeros(2), np.zeros(2, dtype=np.int64), np.zeros(2))
    refresh(drone, limits, (stops, 0.5, 5.0), np.ones(2, dtype=np.bool_), best, (0, np.zeros(0)))
    route_energy(drone, stops, limits)
    without(drone, stops, limits, np.zeros(1))
