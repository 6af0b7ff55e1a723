"""Pricing for the window bound: the best route of one drone for given request prices.

docs/method.md, "The bound". For a drone class (start, landing, the requests it may
serve, its energy model) and profits ``p'_i = λ v_i − π_i``, find the route that
maximises Σ p'_i − E(route) + E(empty route) by labelling **backwards from the
landing**. A label is a route's suffix: its first stop (the label's node), the weight
of its stops (still on board when the drone reaches the node: eq. (6)), its energy
from the node to the landing and its profit. Extending a label with a stop ``j``
before its node adds the leg j → node, flown with the label's weight on board, so its
energy is known and route energy stays additive; completing it adds the leg from the
start, flown with everything.

Relaxations only loosen the bound: a route is elementary within ng-neighbourhoods
(a label remembers the stops of its suffix that lie in the neighbourhood of the node
it moves to, and may not repeat those); with neighbourhoods that cover every request
the routes are elementary. Requests of non-positive profit are left out: dropping a
stop never adds energy (a shorter path by the triangle inequality, lighter legs
before it, and the landing nearest the new last stop is no farther), so the best
route never needs them.

Dominance (same node, at least the profit, at most the weight and the energy, a
subset of the memory) and a bound (the fractional knapsack of the remaining payload
over the profits) prune labels; both are exact. The heuristic mode keeps only the best
few labels per node instead.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..energy import ENERGY_TOL_J, PAYLOAD_TOL_KG, EnergyModel
from .problem import DroneTask, WindowProblem

__all__ = ["DroneClass", "Priced", "price"]

_CHUNK = 2_000_000  # label x request entries formed at once
_EPS = 1e-9
WIDE = 256
"""Requests a pricing may scan per label for one unit of work: a label of a pricing over
``m`` requests counts ``max(1, m / WIDE)`` (extending it forms ``m`` label x request
entries), so the work cap stays proportional to the CPU on a wide window."""
MAX_PRICED = 4096
"""Requests of one drone class a pricing takes at most: a class that may serve more is
not priced (no distance table is built), its routes bounded by the knapsack of its
profits."""


@dataclass(frozen=True)
class DroneClass:
    """Identical drones: where they start and land, what they may serve, their model."""

    start_xy: NDArray[np.float64]
    end: int
    """Fixed end depot, or -1: the depot nearest the last stop."""
    pos: NDArray[np.int64]
    """Positions (in the window's pending arrays) of the requests one drone can serve
    alone within payload and battery."""
    w: NDArray[np.float64]
    dist: NDArray[np.float64]
    """(n, n) distances between those requests."""
    d_start: NDArray[np.float64]
    e_land: NDArray[np.float64]
    """Energy of the empty last leg from each request to the landing."""
    e_empty: float
    """Energy of the empty route (a free drone stays: 0)."""
    model: EnergyModel
    count: int
    ng: NDArray[np.uint64]
    """(n, words) each request's ng-neighbourhood as a bit set (itself included)."""
    priced: bool = True
    """False: more than :data:`MAX_PRICED` requests; ``dist`` and ``ng`` are empty and
    every pricing returns the knapsack bound (:func:`price`)."""

    @property
    def cap(self) -> float:
        return self.model.max_payload_kg + PAYLOAD_TOL_KG

    @property
    def usable(self) -> float:
        return self.model.usable_j + ENERGY_TOL_J

    def e(self, load: NDArray[np.float64]) -> NDArray[np.float64]:
        """Energy per metre with ``load`` on board."""
        m = self.model
        return np.interp(np.minimum(load, m.max_payload_kg), m.grid_kg, m.table_j_per_m)

    @classmethod
    def of(
        cls,
        task: DroneTask,
        problem: WindowProblem,
        land_m: NDArray[np.float64],
        count: int,
        ng: int,
        tables: bool = True,
    ) -> DroneClass:
        """The class of ``count`` drones flying ``task`` in ``problem`` (landing at depot
        ``task.end``; -1: the depot nearest the last stop, ``land_m`` away from each
        request), with ng-neighbourhoods of ``ng`` requests; ``tables`` False (or more
        than :data:`MAX_PRICED` requests): without its distance tables, not priced."""
        model = task.model
        depots_xy = np.asarray(problem.depots_xy, dtype=np.float64)
        req_xy = np.asarray(problem.xy, dtype=np.float64)
        req_w = np.asarray(problem.weight, dtype=np.float64)
        start_xy, end, allowed = depots_xy[task.start], task.end, task.allowed
        e0 = float(model.energy_per_m(0.0))
        end_xy = start_xy if end < 0 else depots_xy[end]
        e_empty = float(np.hypot(*(end_xy - start_xy))) * e0
        pos = np.asarray(allowed, dtype=np.int64)
        xy, w = req_xy[pos], req_w[pos]
        d_start = np.hypot(*(xy - start_xy).T)
        land = land_m[pos] if end < 0 else np.hypot(*(xy - end_xy).T)
        ok = model.fits(w)
        alone = (
            d_start
            * np.interp(np.minimum(w, model.max_payload_kg), model.grid_kg, model.table_j_per_m)
            + land * e0
        )
        ok &= alone <= model.usable_j + ENERGY_TOL_J
        pos, xy, w, d_start, land = pos[ok], xy[ok], w[ok], d_start[ok], land[ok]
        n = pos.size
        if not tables or n > MAX_PRICED:  # (n, n) tables would cost more than the bound
            no_ng = np.zeros((n, 1), dtype=np.uint64)
            none = np.zeros((0, 0))
            return cls(
                start_xy, end, pos, w, none, d_start, land * e0, e_empty, model, count, no_ng, False
            )
        dist = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1])
        words = max(1, -(-n // 64))
        bits = np.zeros((n, words), dtype=np.uint64)
        near = np.argsort(dist, axis=1, kind="stable")[:, : max(ng, 1)]
        rows = np.repeat(np.arange(n), near.shape[1])
        cols = near.ravel()
        one = np.left_shift(np.uint64(1), (cols % 64).astype(np.uint64))
        np.bitwise_or.at(bits, (rows, cols // 64), one)
        return cls(start_xy, end, pos, w, dist, d_start, land * e0, e_empty, model, count, bits)


@dataclass
class Priced:
    """One pricing: the best route value found, a proven upper bound on every route's
    value, and the best routes."""

    best: float
    """Σ p'_i − E + E(empty route) of the best route found; -inf when none was."""
    ub: float
    """No route is worth more (-inf: no route serves a request of positive profit)."""
    routes: list[tuple[tuple[int, ...], float, float]] = field(default_factory=list)
    """(positions in visiting order, energy J, value) of the best routes found."""
    labels: int = 0
    work: float = 0.0
    """Labels made, each counted ``max(1, m / WIDE)`` over ``m`` requests, and the
    knapsack tables' share on a wide pricing (:data:`WIDE`)."""
    cut: str = ""
    """What stopped it short: "work" (``limit``) or "requests" (the class is wider than
    :data:`MAX_PRICED`); "" when neither did."""

    @property
    def exact(self) -> bool:
        """The best route found is the best there is."""
        return self.ub <= self.best + 1e-6


@dataclass
class _Labels:
    node: NDArray[np.int64]
    load: NDArray[np.float64]
    energy: NDArray[np.float64]
    prof: NDArray[np.float64]
    mem: NDArray[np.uint64]
    parent: NDArray[np.int64]
    ub: NDArray[np.float64]
    """What any route through the label is worth at most."""

    def take(self, keep: NDArray[np.int64] | NDArray[np.bool_] | slice) -> _Labels:
        return _Labels(*(a[keep] for a in self._arrays()))

    def _arrays(self) -> tuple[NDArray, ...]:  # type: ignore[type-arg]
        return (self.node, self.load, self.energy, self.prof, self.mem, self.parent, self.ub)

    @property
    def size(self) -> int:
        return int(self.node.size)

    @classmethod
    def concat(cls, parts: list[_Labels]) -> _Labels:
        return cls(*(np.concatenate(a) for a in zip(*(p._arrays() for p in parts), strict=True)))


_KNAP_STEP_KG = 0.01  # weights rounded down to this grid: every feasible set still fits
_REACH_STEP_KG = 0.05  # ... and to this coarser one in the tables by reach
_REACH_LEVELS = 6  # reach levels of those tables
_REACH_MIN = 30  # requests from which a pricing builds them (small ones need none)


class _Bounds:
    """Upper bounds on what extending a label can add (exact relaxations).

    Extending a label at node ``i`` with load ``L`` and energy ``E`` by distinct requests
    J that fit the remaining payload: (1) the route still flies from the start to ``i``
    with at least ``L`` on board (triangle inequality), so it is worth at most the
    completed label's value plus a 0/1 knapsack of the profits over the remaining
    payload; every request of J lies on that flight, so d(start, j) + d(j, i) is at
    most what the battery left flies with ``L`` on board, and only those requests need
    count (tables per node and reach level); (2) each request's incoming leg is at least
    its nearest possible predecessor away and carries its own parcel, so knapsack values
    less that energy also bound it, with ``i``'s own incoming leg at least its nearest
    predecessor away.
    """

    def __init__(
        self,
        cls: DroneClass,
        w: NDArray[np.float64],
        pps: NDArray[np.float64],
        dist: NDArray[np.float64],
        d_start: NDArray[np.float64],
        reach: bool,
    ) -> None:
        self.cls = cls
        near = dist.copy()
        np.fill_diagonal(near, np.inf)
        self.min_in = np.minimum(near.min(axis=0, initial=np.inf), d_start)
        c = self.min_in * cls.e(w)
        self.steps = int(np.floor(cls.cap / _KNAP_STEP_KG + 1e-9))
        units = np.floor(w / _KNAP_STEP_KG + 1e-9).astype(np.int64)
        self.plain = _knapsack(units, pps, self.steps)[0]
        self.net = _knapsack(units, pps - c, self.steps)[0]
        self.by_reach: NDArray[np.float64] | None = None
        if reach:
            # Reach levels: the longest flight the battery allows (empty), in equal parts.
            self.max_m = cls.usable / float(cls.e(np.zeros(1))[0])
            levels = self.max_m * np.arange(1, _REACH_LEVELS + 1) / _REACH_LEVELS
            via = d_start[None, :] + dist  # (i, j): start -> j -> i
            rows = (via[:, None, :] <= levels[None, :, None] + 1e-9).reshape(-1, w.size)
            self.r_steps = int(np.floor(cls.cap / _REACH_STEP_KG + 1e-9))
            r_units = np.floor(w / _REACH_STEP_KG + 1e-9).astype(np.int64)
            table = _knapsack(r_units, pps, self.r_steps, rows)
            self.by_reach = table.reshape(w.size, _REACH_LEVELS, self.r_steps + 1)

    def of(
        self,
        node: NDArray[np.int64],
        load: NDArray[np.float64],
        prof: NDArray[np.float64],
        e_start: NDArray[np.float64],
        e_load: NDArray[np.float64],
        energy: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Upper bound on the value of every route through each label (itself included)."""
        left = self.cls.cap - load
        room = np.clip(np.floor(left / _KNAP_STEP_KG + 1e-9), 0, self.steps).astype(np.int64)
        val = prof - e_start + self.cls.e_empty
        add = self.plain[room]
        if self.by_reach is not None:
            reach_m = (self.cls.usable - energy) / e_load
            lev = np.ceil(reach_m / self.max_m * _REACH_LEVELS - 1e-9).astype(np.int64)
            lev = np.clip(lev, 1, _REACH_LEVELS) - 1
            r_room = np.clip(np.floor(left / _REACH_STEP_KG + 1e-9), 0, self.r_steps)
            add = np.minimum(add, self.by_reach[node, lev, r_room.astype(np.int64)])
        ext1 = val + add
        ext2 = prof - self.min_in[node] * e_load + self.cls.e_empty + self.net[room]
        return np.maximum(val, np.minimum(ext1, ext2))


def _knapsack(
    units: NDArray[np.int64],
    value: NDArray[np.float64],
    steps: int,
    rows: NDArray[np.bool_] | None = None,
) -> NDArray[np.float64]:
    """0/1 knapsack tables: the most value of items (weights in ``units``) within each
    capacity 0..``steps``, one table per row of ``rows`` (which items each may use;
    None: one table of every item)."""
    if rows is None:
        rows = np.ones((1, units.size), dtype=bool)
    best = np.zeros((rows.shape[0], steps + 1))
    for j, (u, v) in enumerate(zip(units.tolist(), value.tolist(), strict=True)):
        if v <= 0 or u > steps:
            continue
        r = np.flatnonzero(rows[:, j])
        if not r.size:
            continue
        sub = best[r]
        sub[:, u:] = np.maximum(sub[:, u:], sub[:, : steps + 1 - u] + v)
        best[r] = sub
    return best


def _has(mem: NDArray[np.uint64], j: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Whether request ``j`` (per column) is in each label's memory: (L, m)."""
    word = mem[:, (j // 64)]
    return ((word >> (j % 64).astype(np.uint64)[None, :]) & np.uint64(1)).astype(bool)


def _dominated(lab: _Labels) -> NDArray[np.bool_]:
    """Labels another label at the same node dominates (ties: the earlier one stays)."""
    n = lab.size
    out = np.zeros(n, dtype=bool)
    order = np.lexsort((lab.energy, lab.load, -lab.prof, lab.node))
    node = lab.node[order]
    cuts = np.flatnonzero(np.diff(node)) + 1
    starts = np.concatenate([[0], cuts])
    ends = np.concatenate([cuts, [n]])
    for a, b in zip(starts, ends, strict=True):
        g = b - a
        if g < 2:
            continue
        idx = order[a:b]
        ld, en = lab.load[idx], lab.energy[idx]
        # Candidates: an earlier label (at least the profit) with no more load and energy;
        # the memory test only on those pairs.
        m = (ld[:, None] <= ld[None, :] + _EPS) & (en[:, None] <= en[None, :] + 1e-6)
        rank = np.arange(g)
        m &= rank[:, None] < rank[None, :]  # only an earlier label dominates a later one
        i, j = np.nonzero(m)
        if not i.size:
            continue
        mem = lab.mem[idx]
        sub = ~np.any(mem[i] & ~mem[j], axis=1)
        dom = np.zeros(g, dtype=bool)
        dom[j[sub]] = True
        out[idx] = dom
    return out


def price(
    cls: DroneClass,
    profit: NDArray[np.float64],
    threshold: float,
    *,
    keep: int | None = None,
    max_labels: int = 20_000,
    n_routes: int = 8,
    budget: float = np.inf,
    limit: float = np.inf,
) -> Priced:
    """The best route of drone class ``cls`` for request profits ``profit`` (per window
    position), a proven upper bound on every route's value, and the best routes worth
    more than ``threshold`` (module docstring).

    ``keep``: extend only the best ``keep`` labels per node (a heuristic); None: every
    non-dominated label, at most ``max_labels`` of one length (a twentieth once more
    than ``budget`` work was done: a count, so the result is the same on any machine),
    those of highest upper bound. ``limit``: the work a wide pricing (over more than
    :data:`WIDE` requests) may do at most; it stops before a level of labels that
    would pass it, and is not started when its tables and first labels would.
    Labels left out count with their upper bound in ``Priced.ub``, so the bound stays
    valid either way.
    """
    pp = profit[cls.pos]
    sub = np.flatnonzero(pp > _EPS)
    res = Priced(-np.inf, -np.inf)
    if sub.size == 0:
        return res
    w, pps = cls.w[sub], pp[sub]
    # A label scans every request when it is extended: over more than WIDE requests it
    # counts for more than one, and so do the pricing's tables (about two levels of
    # labels' CPU); up to WIDE requests a label is one, as the label caps count.
    per = max(1.0, sub.size / WIDE)
    wide = sub.size > WIDE
    setup = 2.0 * sub.size * per if wide and sub.size >= _REACH_MIN else 0.0
    if not cls.priced or (wide and setup + sub.size * per > limit):
        # No route fits more profit than the payload's 0/1 knapsack of the profits, and
        # none flies less than the empty route (weights rounded down: still a bound).
        steps = int(np.floor(cls.cap / _KNAP_STEP_KG + 1e-9))
        units = np.floor(w / _KNAP_STEP_KG + 1e-9).astype(np.int64)
        res.ub = float(_knapsack(units, pps, steps)[0, steps])
        res.cut = "requests" if cls.pos.size > MAX_PRICED else "work"
        return res
    dist = cls.dist[np.ix_(sub, sub)]
    d_start, e_land = cls.d_start[sub], cls.e_land[sub]
    local = sub  # bit index of each request: its index in the class (memory is per class)
    bounds = _Bounds(cls, w, pps, dist, d_start, reach=sub.size >= _REACH_MIN)
    within = _Within(cls, w, pps, dist, d_start, cls.ng[sub], local, bounds)
    # Labels of one stop: the request, then the landing.
    n = sub.size
    lab = _Labels(
        np.arange(n),
        w.copy(),
        e_land.copy(),
        pps - e_land,
        np.zeros((n, cls.ng.shape[1]), dtype=np.uint64),
        np.full(n, -1, dtype=np.int64),
        np.zeros(n),
    )
    e_l = cls.e(lab.load)
    lab.ub = bounds.of(lab.node, lab.load, lab.prof, d_start * e_l, e_l, lab.energy)
    lab.mem[np.arange(n), local // 64] = np.left_shift(np.uint64(1), (local % 64).astype(np.uint64))
    levels: list[tuple[NDArray[np.int64], NDArray[np.int64]]] = []
    best, left_out = -np.inf, -np.inf
    found: list[tuple[float, int, int, float]] = []  # value, level, label, energy
    total, work = 0, setup
    while lab.size:
        if wide and work + lab.size * per > limit:
            # Out of work: every route through these labels is worth at most their bound.
            left_out = max(left_out, float(lab.ub.max()))
            res.cut = "work"
            break
        total += lab.size
        work += lab.size * per
        e_start = d_start[lab.node] * cls.e(lab.load)
        val = lab.prof - e_start + cls.e_empty
        fits = lab.energy + e_start <= cls.usable  # else no route through it fits
        lab, val, e_start = lab.take(fits), val[fits], e_start[fits]
        if not lab.size:
            break
        levels.append((lab.node, lab.parent))
        top = np.argsort(-val, kind="stable")[:n_routes]
        found.extend(
            (float(val[i]), len(levels) - 1, int(i), float(lab.energy[i] + e_start[i]))
            for i in top
            if val[i] > threshold
        )
        best = max(best, float(val.max()))
        # Labels whose routes are worth at most ``bar`` go no further; ``bar`` counts
        # towards the bound (a route worth less than the threshold is of no interest).
        bar = max(best, threshold)
        idx = np.flatnonzero(lab.ub > bar + 1e-6)
        if not idx.size:
            break
        nxt = _extend(lab.take(idx), idx, within, bar)
        if keep is None:
            # A full pricing keeps the labels of highest upper bound when there are too
            # many (or it is late): what it leaves out then bounds the rest least.
            cap = max_labels if work <= budget else max_labels // 20
            if nxt.size > cap:
                nxt, dropped = _best_by_bound(nxt, cap)
                left_out = max(left_out, dropped)
            nxt = nxt.take(~_dominated(nxt))
        elif nxt.size:
            nxt, dropped = _best_per_node(nxt, keep)
            left_out = max(left_out, dropped)
        lab = nxt
    res.best, res.labels, res.work = best, total, work
    # Routes left out were worth at most the threshold, or their label's bound.
    res.ub = max(best, left_out, threshold)
    found.sort(key=lambda f: -f[0])
    for v, lev, i, energy in found[:n_routes]:
        stops = []
        k = i
        for lv in range(lev, -1, -1):
            node, parent = levels[lv]
            stops.append(int(cls.pos[sub[node[k]]]))
            k = int(parent[k])
        res.routes.append((tuple(stops), energy, v))
    return res


@dataclass(frozen=True)
class _Within:
    """A pricing's requests of positive profit: what extending a label reads."""

    cls: DroneClass
    w: NDArray[np.float64]
    pps: NDArray[np.float64]
    """Their profits."""
    dist: NDArray[np.float64]
    d_start: NDArray[np.float64]
    ng: NDArray[np.uint64]
    local: NDArray[np.int64]
    """Each one's bit in a label's memory (its index in the class)."""
    bounds: _Bounds


def _extend(lab: _Labels, idx: NDArray[np.int64], within: _Within, bar: float) -> _Labels:
    """Every label extended by every request before its node that fits and whose routes
    can be worth more than ``bar``."""
    cls, w, pps, dist = within.cls, within.w, within.pps, within.dist
    d_start, ng, local, bounds = within.d_start, within.ng, within.local, within.bounds
    m = pps.size
    e_lab = cls.e(lab.load)
    out: list[_Labels] = []
    step = max(1, _CHUNK // max(m, 1))
    for c in range(0, lab.size, step):
        part = lab.take(slice(c, c + step))
        el = e_lab[c : c + step]
        leg = dist[:, part.node].T * el[:, None]  # (L, m): j -> node with the label's load
        load = part.load[:, None] + w[None, :]
        energy = part.energy[:, None] + leg
        ok = (load <= cls.cap) & ~_has(part.mem, local)
        li, j = np.nonzero(ok)
        load, energy = load[li, j], energy[li, j]
        e_new = cls.e(load)
        e_start = d_start[j] * e_new
        keep = energy + e_start <= cls.usable
        li, j = li[keep], j[keep]
        load, energy, e_new, e_start = load[keep], energy[keep], e_new[keep], e_start[keep]
        prof = part.prof[li] + pps[j] - leg[li, j]
        ub = bounds.of(j, load, prof, e_start, e_new, energy)
        keep = ub > bar + 1e-6
        li, j = li[keep], j[keep]
        load, energy, prof, ub = load[keep], energy[keep], prof[keep], ub[keep]
        mem = part.mem[li] & ng[j]
        mem[np.arange(li.size), local[j] // 64] |= np.left_shift(
            np.uint64(1), (local[j] % 64).astype(np.uint64)
        )
        out.append(_Labels(j, load, energy, prof, mem, idx[c + li], ub))
    return _Labels.concat(out)


def _best_by_bound(lab: _Labels, cap: int) -> tuple[_Labels, float]:
    """The ``cap`` labels of highest upper bound, and the highest bound left out."""
    order = np.argsort(-lab.ub, kind="stable")
    return lab.take(np.sort(order[:cap])), float(lab.ub[order[cap]])


def _best_per_node(lab: _Labels, keep: int) -> tuple[_Labels, float]:
    """The ``keep`` labels of highest profit at each node, and the highest upper bound
    of those left out (-inf: none)."""
    order = np.lexsort((-lab.prof, lab.node))
    node = lab.node[order]
    first = np.concatenate([[0], np.flatnonzero(np.diff(node)) + 1])
    rank = np.arange(node.size) - np.repeat(first, np.diff(np.append(first, node.size)))
    kept = rank < keep
    dropped = float(lab.ub[order[~kept]].max(initial=-np.inf))
    return lab.take(np.sort(order[kept])), dropped
