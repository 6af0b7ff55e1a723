"""Visiting order of every subset of a drone's candidates (docs/method.md §4).

A subset of the ``n`` candidates is a bitmask (bit ``j`` = candidate ``j``). Both
methods work on all ``2**n`` subsets at once, vectorised over masks:

* ``exact``: the energy-minimal order, by a backward dynamic program over subsets.
  With ``e(w)`` the energy per metre with ``w`` kg on board and ``w(R)`` the weight
  of the parcels still to deliver,

      f(∅, i) = d(i, end) · e(0)
      f(R, i) = min_{j ∈ R}  d(i, j) · e(w(R)) + f(R \\ {j}, j)

  and a plan ``S`` costs ``f(S, start)``. The payload leaving a node is fixed by the
  set still to deliver (eq. (6)), so one table gives the optimal order of every
  subset.
* ``greedy``: the paper's nearest-neighbour order by distance (start, nearest
  unvisited, ..., end); ties go to the lower candidate index.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..energy import EnergyModel

__all__ = [
    "MAX_STOPS",
    "SubsetOrders",
    "best_order",
    "evaluate_orders",
    "exact_orders",
    "node_distances",
    "subset_energies",
    "subset_masks",
    "subset_orders",
]

MAX_STOPS = 12
"""Most candidates one drone may have: 2**12 subsets, ~10 ms for the exact order."""

Ordering = Literal["exact", "greedy"]


@dataclass(frozen=True)
class SubsetOrders:
    """Order, length and energy of the route of every subset (row = bitmask)."""

    order: NDArray[np.int8]
    """``(2**n, n)`` candidate positions in visiting order, padded with -1."""
    size: NDArray[np.int64]
    """``(2**n,)`` number of stops."""
    weight_kg: NDArray[np.float64]
    """``(2**n,)`` total parcel weight."""
    distance_m: NDArray[np.float64]
    """``(2**n,)`` route length start → stops → end."""
    energy_j: NDArray[np.float64]
    """``(2**n,)`` route energy; ``inf`` where the weight exceeds the payload limit."""

    def route(self, mask: int) -> tuple[int, ...]:
        """Candidate positions of subset ``mask`` in visiting order."""
        return tuple(int(j) for j in self.order[mask] if j >= 0)


@lru_cache(maxsize=MAX_STOPS + 1)
def subset_masks(n: int) -> tuple[NDArray[np.bool_], list[NDArray[np.int64]]]:
    """Membership matrix ``(2**n, n)`` and the masks grouped by number of members."""
    masks = np.arange(1 << n, dtype=np.int64)
    bits = ((masks[:, None] >> np.arange(n)) & 1).astype(bool)
    size = bits.sum(axis=1)
    layers = [masks[size == k] for k in range(n + 1)]
    bits.setflags(write=False)
    return bits, layers


def node_distances(start_xy: ArrayLike, end_xy: ArrayLike, xy: ArrayLike) -> NDArray[np.float64]:
    """Euclidean matrix over nodes: candidates ``0..n-1``, start ``n``, end ``n + 1``."""
    pts = np.vstack(
        [np.reshape(xy, (-1, 2)), np.reshape(start_xy, (1, 2)), np.reshape(end_xy, (1, 2))]
    ).astype(np.float64)
    diff = pts[:, None, :] - pts[None, :, :]
    return np.hypot(diff[..., 0], diff[..., 1])


def exact_orders(
    d: NDArray[np.float64], e_mask: NDArray[np.float64], e0: float, n: int
) -> NDArray[np.int8]:
    """The energy-minimal visiting order of every subset (module docstring), by the
    backward dynamic program layer by layer (all masks of one size at once).

    ``d`` is :func:`node_distances`' matrix, ``e_mask`` the energy per metre with each
    mask's parcels on board, ``e0`` empty; returns ``(2**n, n)`` orders padded with -1.
    """
    bits, layers = subset_masks(n)
    size = 1 << n
    pow2 = np.int64(1) << np.arange(n, dtype=np.int64)
    cols = np.arange(n)
    f = np.empty((size, n + 1))  # f[R, i], i in candidates or start (= n)
    nxt = np.full((size, n + 1), -1, dtype=np.int8)
    f[0] = d[: n + 1, n + 1] * e0
    leg = d[: n + 1, :n]  # (from i, to j)
    for masks in layers[1:]:
        tail = np.where(bits[masks], f[masks[:, None] ^ pow2, cols], np.inf)  # f(R\{j}, j)
        cand = e_mask[masks, None, None] * leg + tail[:, None, :]  # (m, n + 1, n)
        best = cand.argmin(axis=2)
        f[masks] = np.take_along_axis(cand, best[..., None], axis=2)[..., 0]
        nxt[masks] = best
    return _unroll(nxt, n)


def _unroll(nxt: NDArray[np.int8], n: int) -> NDArray[np.int8]:
    """Follow the successor table from the start for every mask at once."""
    size = 1 << n
    order = np.full((size, n), -1, dtype=np.int8)
    rest = np.arange(size, dtype=np.int64)
    node = np.full(size, n, dtype=np.int64)
    for t in range(n):
        active = rest != 0
        j = np.where(active, nxt[rest, node], 0).astype(np.int64)
        order[:, t] = np.where(active, j, -1)
        rest = np.where(active, rest ^ (np.int64(1) << j), rest)
        node = np.where(active, j, node)
    return order


def _greedy(d: NDArray[np.float64], n: int) -> NDArray[np.int8]:
    """Nearest unvisited candidate by distance, every mask at once."""
    bits, _ = subset_masks(n)
    size = 1 << n
    order = np.full((size, n), -1, dtype=np.int8)
    rest = bits.copy()
    node = np.full(size, n, dtype=np.int64)
    rows = np.arange(size)
    for t in range(n):
        active = rest.any(axis=1)
        j = np.where(rest, d[node, :n], np.inf).argmin(axis=1)
        order[:, t] = np.where(active, j, -1)
        rest[rows[active], j[active]] = False
        node = np.where(active, j, node)
    return order


def evaluate_orders(
    order: NDArray[np.int8],
    d: NDArray[np.float64],
    w: NDArray[np.float64],
    total: NDArray[np.float64],
    model: EnergyModel,
    n: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Length and energy of each ordered route; the drop-off of eq. (6) along the way."""
    size = order.shape[0]
    cap = model.max_payload_kg
    on_board = total.copy()
    node = np.full(size, n, dtype=np.int64)
    dist = np.zeros(size)
    energy = np.zeros(size)
    for t in range(n):
        j = order[:, t].astype(np.int64)
        active = j >= 0
        j = np.where(active, j, 0)
        leg = np.where(active, d[node, j], 0.0)
        dist += leg
        energy += model.leg_energy_j(leg, np.clip(on_board, 0.0, cap))  # eq. (9)
        on_board = np.where(active, on_board - w[j], on_board)
        node = np.where(active, j, node)
    last = d[node, n + 1]
    return dist + last, energy + model.leg_energy_j(last, 0.0)


def subset_orders(
    start_xy: ArrayLike,
    end_xy: ArrayLike,
    customers_xy: ArrayLike,
    weights_kg: ArrayLike,
    model: EnergyModel,
    method: Ordering = "exact",
) -> SubsetOrders:
    """Visiting order, length and energy of the route of every subset of the candidates.

    Subsets heavier than the payload limit get an order but ``energy_j = inf``.
    """
    w = np.asarray(weights_kg, dtype=np.float64).reshape(-1)
    n = w.size
    if n > MAX_STOPS:
        raise ValueError(f"expected at most {MAX_STOPS} candidates, got {n}")
    if np.reshape(customers_xy, (-1, 2)).shape[0] != n:
        raise ValueError("expected one location per parcel weight")
    if np.any(w < 0):
        raise ValueError("expected parcel weights >= 0")
    bits, _ = subset_masks(n)
    d = node_distances(start_xy, end_xy, customers_xy)
    total = bits @ w
    cap = model.max_payload_kg
    over = ~model.fits(total)
    if method == "exact":
        e_mask = model.energy_per_m(np.minimum(total, cap))
        order = exact_orders(d, e_mask, float(model.energy_per_m(0.0)), n)
    elif method == "greedy":
        order = _greedy(d, n)
    else:
        raise ValueError(f"expected ordering 'exact' or 'greedy', got {method!r}")
    dist, energy = evaluate_orders(order, d, w, total, model, n)
    energy[over] = np.inf
    return SubsetOrders(
        order=order, size=bits.sum(axis=1), weight_kg=total, distance_m=dist, energy_j=energy
    )


def best_order(
    start_xy: ArrayLike,
    end_xy: ArrayLike,
    customers_xy: ArrayLike,
    weights_kg: ArrayLike,
    model: EnergyModel,
    method: Ordering = "exact",
) -> tuple[int, ...]:
    """Visiting order (candidate positions) of the route through all the candidates."""
    orders = subset_orders(start_xy, end_xy, customers_xy, weights_kg, model, method)
    return orders.route(orders.order.shape[0] - 1)


def subset_energies(
    start_xy: ArrayLike,
    end_xy: ArrayLike,
    customers_xy: ArrayLike,
    weights_kg: ArrayLike,
    model: EnergyModel,
    free_end_m: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Exact route energy of every subset, for a batch of drones at once.

    ``start_xy``/``end_xy`` are ``(B, 2)``, ``customers_xy`` ``(B, n, 2)``, ``weights_kg``
    ``(B, n)``; a drone with fewer candidates pads with ``inf`` weights (subsets that
    hold a pad are infeasible). Returns ``(energy (B, 2**n), weight (B, 2**n), members
    (2**n, n))``: the energy of the best visiting order (the same backward dynamic
    program as :func:`subset_orders`, without the orders), ``inf`` over the payload.
    One numpy pass per subset size for the whole batch, so a policy can price every
    action of a drone in one call.

    ``free_end_m`` ``(B, n)``: the route has no fixed end; after its last customer i it
    flies ``free_end_m[b, i]`` metres empty (to the depot nearest i), and the empty route
    stays at the start (``end_xy`` is then ignored). A row of only NaN keeps its fixed
    end, so fixed and free routes can share one call.
    """
    xy = np.asarray(customers_xy, dtype=np.float64)
    w = np.asarray(weights_kg, dtype=np.float64)
    b, n = w.shape
    s = np.asarray(start_xy, dtype=np.float64).reshape(b, 1, 2)
    e = np.asarray(end_xy, dtype=np.float64).reshape(b, 1, 2)
    pts = np.concatenate([np.where(np.isfinite(xy), xy, s), s, e], axis=1)  # (B, n + 2, 2)
    diff = pts[:, :, None, :] - pts[:, None, :, :]
    d = np.hypot(diff[..., 0], diff[..., 1])
    bits, layers = subset_masks(n)
    size = 1 << n
    total = np.where(np.isfinite(w), w, 0.0) @ bits.T  # (B, 2**n)
    pad = ~np.isfinite(w)
    over = ~model.fits(total) | (pad.astype(np.int64) @ bits.T > 0)
    e_mask = model.energy_per_m(np.minimum(total, model.max_payload_kg))
    pow2 = np.int64(1) << np.arange(n, dtype=np.int64)
    cols = np.arange(n)
    f = np.empty((b, size, n + 1))
    f[:, 0] = d[:, : n + 1, n + 1] * float(model.energy_per_m(0.0))
    if free_end_m is not None:
        free = np.asarray(free_end_m, dtype=np.float64).reshape(b, n)
        rows = ~np.all(np.isnan(free), axis=1)  # the rows with a free end
        e0 = float(model.energy_per_m(0.0))
        f[rows, 0, :n] = np.where(np.isfinite(free[rows]), free[rows], 0.0) * e0
        f[rows, 0, n] = 0.0
    leg = d[:, : n + 1, :n]  # (B, from i, to j)
    for masks in layers[1:]:
        tail = np.where(bits[masks], f[:, masks[:, None] ^ pow2, cols], np.inf)  # (B, m, n)
        cand = e_mask[:, masks, None, None] * leg[:, None] + tail[:, :, None, :]
        f[:, masks] = cand.min(axis=3)
    energy = f[:, :, n].copy()
    energy[over] = np.inf
    return energy, total, bits
