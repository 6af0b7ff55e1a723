"""The planners: each drone's candidate plans for one window (docs/method.md §4, §7).

A :class:`Planner` is chosen once from the config (:func:`make_planner`) and builds, for a
window and the drones' actions, every drone's plan set and where each plan lands; the
selection program then picks one plan per drone (``window.py``). Three planners:

* :class:`SubsetsPlanner`: the paper's (Alg. 2): every feasible subset of each drone's
  M̂ candidates, in its flight range (scope ``range``) or, OPS-global (scope ``global``),
  among the U·M̂ most delayed requests of the whole map, each drone taking the M̂ of them
  nearest its depot and each plan landing at the depot nearest its last customer.
* :class:`RoutePoolPlanner`: the route pool (docs/method.md, "Route pool").
* :class:`PyvrpPoolPlanner`: the route pool with PyVRP's routes as extra columns
  (``pyvrp_iterations`` > 0).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..config import PlanConfig
from ..energy import EnergyModel
from ..segment.depots import nearest_depot
from .candidates import by_delay, draft, range_candidates
from .plans import Candidates, PlanSet, build_plans
from .pool import build_pool
from .pool_state import pack_priced
from .problem import DroneTask, Scope, WindowProblem, can_reach
from .view import EVERY_DEPOT, FREE, WindowView

__all__ = [
    "DronePlans",
    "Planner",
    "PyvrpPoolPlanner",
    "RoutePoolPlanner",
    "Scope",
    "SubsetsPlanner",
    "can_reach",
    "make_planner",
]


@dataclass(frozen=True)
class DronePlans:
    """What a planner gives the selection for one window."""

    plan_sets: list[PlanSet]
    """Each drone's plans; plan 0 is its empty plan."""
    ends: list[np.ndarray]
    """Each drone's plans' end depots; -1: the depot nearest the last customer, fixed
    once the chosen route is ordered."""
    actions: np.ndarray
    """``(U,)`` the actions the drones fly (a destination out of reach becomes stay)."""
    candidates_s: float
    """Seconds spent choosing candidates (the route pool: building its routes)."""
    reorder: bool
    """The chosen routes still get their energy-minimal order and landing
    (:func:`~marops_cli.plans.pool.finish_route`): the route pool stores routes in
    insertion order."""


class Planner(Protocol):
    """Builds each drone's plans for one window's problem."""

    @property
    def scope(self) -> Scope:
        """The scope the planner plans in, which also builds its window's problem
        (:func:`.window.plan_routes`)."""
        ...

    def plans(self, problem: WindowProblem, view: WindowView) -> DronePlans:
        """Plan sets and ends for ``problem`` (the drones' tasks, their models, λ and the
        prices); ``view`` is the window it was built from (the paper's candidates rank
        its requests by delay, due time and service area)."""
        ...


@dataclass(frozen=True)
class SubsetsPlanner:
    """The paper's planner: every feasible subset of each drone's candidates."""

    cfg: PlanConfig
    scope: Scope = "range"

    def plans(self, problem: WindowProblem, view: WindowView) -> DronePlans:
        models = problem.models
        if self.scope == "global":  # no flight range: every drone starts as "stay"
            acts = np.zeros(view.n_drones, dtype=np.int64)
            plan_sets, plan_ends, t_cand = _global_plans(view, models, self.cfg)
            return DronePlans(plan_sets, plan_ends, acts, t_cand, reorder=False)
        # The paper's planner has no free landing: FREE flies as stay.
        acts = np.where(problem.actions == FREE, 0, problem.actions)
        plan_sets, ends, t_cand = _range_plans(view, acts, models, self.cfg)
        plan_ends = [np.full(ps.n_plans, ends[u]) for u, ps in enumerate(plan_sets)]
        return DronePlans(plan_sets, plan_ends, acts, t_cand, reorder=False)


@dataclass(frozen=True)
class RoutePoolPlanner:
    """The route pool: many good routes per drone from construction and ruin and
    recreate (docs/method.md, "Route pool")."""

    cfg: PlanConfig
    scope: Scope = "range"

    def pyvrp_iterations(self) -> int:
        """PyVRP iterations whose routes join the pool: none (:class:`PyvrpPoolPlanner`)."""
        return 0

    def plans(self, problem: WindowProblem, view: WindowView) -> DronePlans:
        plan_sets, plan_ends, t_cand = _pool_plans(problem, self.cfg, self.pyvrp_iterations())
        return DronePlans(plan_sets, plan_ends, problem.actions, t_cand, reorder=True)


@dataclass(frozen=True)
class PyvrpPoolPlanner(RoutePoolPlanner):
    """The route pool with PyVRP's routes for the window as extra columns, each re-costed
    exactly (``cfg.pyvrp_iterations`` iterations; needs the pyvrp extra)."""

    def pyvrp_iterations(self) -> int:
        return self.cfg.pyvrp_iterations


def make_planner(cfg: PlanConfig, scope: Scope = "range") -> Planner:
    """The planner ``cfg.planner`` names, for flight ranges or the whole map (``scope``)."""
    if scope not in ("range", "global"):
        raise ValueError(f"expected scope 'range' or 'global', got {scope!r}")
    if cfg.planner == "pool":
        pool = PyvrpPoolPlanner if cfg.pyvrp_iterations > 0 else RoutePoolPlanner
        return pool(cfg, scope)
    return SubsetsPlanner(cfg, scope)


_NONE = np.zeros(0, dtype=np.int64)


def _own_range_candidates(
    view: WindowView, ranked: tuple[np.ndarray, np.ndarray], u: int, s: int, a: int, m: int
) -> np.ndarray:
    """:func:`range_candidates` of drone ``u`` among the parcels stocked at its depot ``s``
    (all of them under the paper's model); none when it cannot fly. ``ranked``: the
    pending positions by :func:`by_delay` and their service areas."""
    if not view.ready(u):
        return _NONE
    rank, rank_area = ranked
    stock = view.pending_stock[rank]
    keep = (stock == s) | (stock == EVERY_DEPOT)
    rank, rank_area = rank[keep], rank_area[keep]
    return range_candidates(view, rank, rank_area, s, a, m)


def _drafted_candidates(
    view: WindowView, rank: np.ndarray, rank_area: np.ndarray, acts: np.ndarray, m_hat: int
) -> list[np.ndarray]:
    """Candidates by draft: drones take turns (snake order) claiming the most delayed
    unclaimed request in their range, M̂ rounds; a drone left short tops up with requests
    others claimed, so the selection can still arbitrate between them.

    Each drone's preference order is :func:`pick_candidates`' (delay, then distance to
    its depot and due time as ``view.ties`` orders them, then index); only the head of
    its range that the draft can reach is sorted.
    """
    head = m_hat * (view.n_drones + 1)  # the most any drone can reach in the draft
    prefs = [
        _own_range_candidates(view, (rank, rank_area), u, int(s), int(a), head)
        for u, (s, a) in enumerate(zip(view.drone_depot, acts, strict=True))
    ]
    return draft(prefs, view.pending_idx.size, m_hat)


def _range_plans(
    view: WindowView, acts: np.ndarray, models: list[EnergyModel], cfg: PlanConfig
) -> tuple[list[PlanSet], np.ndarray, float]:
    """The paper's plan sets of the drones flying ``acts`` (each reachable, and 0 for a
    drone that cannot fly) and each drone's destination."""
    dep = view.depots
    t0 = time.perf_counter()
    rank = by_delay(view)
    rank_area = view.pending_area[rank]
    if cfg.candidates == "draft":
        cands = _drafted_candidates(view, rank, rank_area, acts, cfg.max_parcels)
    else:
        # Drones at the same depot taking the same action have the same candidates.
        by_key: dict[tuple[int, int], np.ndarray] = {}
        cands = []
        for u, s in enumerate(view.drone_depot):
            sa = (int(s), int(acts[u]))
            if not view.ready(u):
                cands.append(_NONE)
                continue
            if sa not in by_key:
                ranked = (rank, rank_area)
                by_key[sa] = _own_range_candidates(view, ranked, u, *sa, cfg.max_parcels)
            cands.append(by_key[sa])
    t_cand = time.perf_counter() - t0
    plan_sets: list[PlanSet] = []
    ends = np.zeros(view.n_drones, dtype=np.int64)
    done: dict[tuple[int, int, bytes, int], PlanSet] = {}  # identical inputs, identical plans
    for u, s0 in enumerate(view.drone_depot):
        s, cand = int(s0), cands[u]
        dest = int(dep.candidates[s, acts[u]])
        key = (s, dest, cand.tobytes(), id(models[u]))
        if key not in done:
            own = Candidates(view.pending_xy[cand], view.pending_weight[cand], cand)
            done[key] = build_plans(dep.xy[s], dep.xy[dest], own, models[u], cfg)
        plan_sets.append(done[key])
        ends[u] = dest
    return plan_sets, ends, t_cand


def _global_plans(
    view: WindowView, models: list[EnergyModel], cfg: PlanConfig
) -> tuple[list[PlanSet], list[np.ndarray], float]:
    """OPS-global candidates; returns each drone's plan sets and each plan's end depot."""
    dep = view.depots
    t0 = time.perf_counter()
    n_pool = view.n_drones * cfg.max_parcels
    order = np.lexsort(
        (np.arange(view.pending_idx.size), view.pending_due_s, -view.pending_delay_h)
    )
    pool = order[:n_pool]
    # Distance from every pooled request to every depot, and its nearest depot, once for
    # all drones.
    pxy = view.pending_xy[pool]
    d_pool = np.hypot(pxy[:, None, 0] - dep.xy[None, :, 0], pxy[:, None, 1] - dep.xy[None, :, 1])
    near, d_near = nearest_depot(pxy, dep.xy)
    # Each drone's pool positions, nearest its depot first (ties to the lower index).
    nearest = {int(s): np.lexsort((pool, d_pool[:, int(s)])) for s in set(view.drone_depot)}
    stock = view.pending_stock  # only the parcels stocked at the drone's depot
    nearest = {
        s: p[(stock[pool[p]] == s) | (stock[pool[p]] == EVERY_DEPOT)] for s, p in nearest.items()
    }
    prefs = [nearest[int(s)] if view.ready(u) else _NONE for u, s in enumerate(view.drone_depot)]
    drafted = None
    if cfg.candidates == "draft":
        drafted = draft(prefs, pool.size, cfg.max_parcels)
    t_cand = time.perf_counter() - t0
    plan_sets, plan_ends = [], []
    done: dict[tuple[int, bytes, int], tuple[PlanSet, np.ndarray]] = {}  # same in, same out
    for u, s0 in enumerate(view.drone_depot):
        s, model = int(s0), models[u]
        e0 = float(model.energy_per_m(0.0))
        sel = prefs[u][: cfg.max_parcels] if drafted is None else drafted[u]
        key = (s, sel.tobytes(), id(model))
        if key in done:
            plan_sets.append(done[key][0])
            plan_ends.append(done[key][1])
            continue
        d = d_pool[:, s]
        cand = pool[sel]
        own = Candidates(view.pending_xy[cand], view.pending_weight[cand], cand)
        ps = build_plans(dep.xy[s], dep.xy[s], own, model, cfg)
        # Land at the depot nearest the last customer instead of flying back: the
        # last leg is flown empty, so only its length changes (never longer).
        sizes = (ps.order >= 0).sum(axis=1)
        ends = np.full(ps.n_plans, s, dtype=np.int64)
        energy, distance = ps.energy_j.copy(), ps.distance_m.copy()
        has = sizes > 0  # (no candidates at all: only the empty plan, nothing to index)
        if has.any():
            last = sel[ps.order[has, sizes[has] - 1]]
            ends[has] = near[last]
            distance[has] += d_near[last] - d[last]
            energy[has] += e0 * (d_near[last] - d[last])
        done[key] = (
            PlanSet(ps.request_ids, ps.members, ps.order, energy, distance, ps.weight_kg),
            ends,
        )
        plan_sets.append(done[key][0])
        plan_ends.append(ends)
    return plan_sets, plan_ends, t_cand


def _pool_plans(
    problem: WindowProblem, cfg: PlanConfig, pyvrp_iterations: int = 0
) -> tuple[list[PlanSet], list[np.ndarray], float]:
    """Route-pool plan sets (docs/method.md, "Route pool") and each plan's end depot;
    with ``pyvrp_iterations`` PyVRP's routes join the pool as extra columns."""
    depots_xy = problem.depots_xy
    t0 = time.perf_counter()
    res = build_pool(
        problem,
        n_candidates=cfg.pool_candidates,
        iterations=cfg.pool_iterations,
        seed=problem.t,
        pack=cfg.pack_price,
    )
    routes = [dict(zip(r, e, strict=True)) for r, e in zip(res.routes, res.energy_j, strict=True)]
    if pyvrp_iterations > 0:
        _add_pyvrp_routes(problem, pyvrp_iterations, routes, cfg.pack_price)
    t_cand = time.perf_counter() - t0
    plan_sets, plan_ends = [], []
    for u, task in enumerate(problem.tasks):
        empty_end = task.start if task.end < 0 else task.end
        flight = float(np.hypot(*(depots_xy[empty_end] - depots_xy[task.start])))
        keys = list(routes[u])
        ids = np.unique(np.array([i for k in keys for i in k], dtype=np.int64))
        n_k = len(keys) + 1
        members = np.zeros((n_k, ids.size), dtype=bool)
        order = np.full((n_k, max(ids.size, 1)), -1, dtype=np.int16)
        energy = np.empty(n_k)
        energy[0] = float(task.model.leg_energy_j(flight, 0.0))
        for k, key in enumerate(keys, start=1):
            col = np.searchsorted(ids, np.array(key, dtype=np.int64))
            members[k, col] = True
            order[k, : col.size] = col
            energy[k] = routes[u][key]
        weight = members @ problem.weight[ids] if ids.size else np.zeros(n_k)
        # Distances are recomputed for the chosen routes; the table needs energies only.
        plan_sets.append(PlanSet(ids, members, order, energy, np.zeros(n_k), weight))
        plan_ends.append(np.full(n_k, task.end, dtype=np.int64))
    return plan_sets, plan_ends, t_cand


def _add_pyvrp_routes(
    problem: WindowProblem,
    iterations: int,
    routes: list[dict[tuple[int, ...], float]],
    pack: float = 0.0,
) -> None:
    """PyVRP's routes for the window as extra columns, each re-costed exactly and priced
    as the pool prices its own (``pack``: ``[plan] pack_price``)."""
    from .pyvrp_routes import solve_window  # the optional pyvrp extra, loaded when asked for

    tasks = problem.tasks
    allowed = np.zeros((len(tasks), problem.n_requests), dtype=bool)
    for u, t in enumerate(tasks):
        allowed[u, t.allowed] = True
    peer = solve_window(problem, iterations=iterations, seed=problem.t)
    for s, stops in zip(peer.start, peer.stops, strict=True):
        for u, t in enumerate(tasks):
            if t.start != int(s) or not allowed[u, stops].all():
                continue
            own = t.model  # the drone's own limits (a mixed fleet)
            if not own.fits(float(problem.weight[stops].sum())):
                continue  # PyVRP loads to the largest payload: too heavy for this drone
            e, priced = _route_energy_j(problem, t, stops, pack)
            if e <= own.usable_j:
                routes[u].setdefault(tuple(int(i) for i in stops), priced)


def _route_energy_j(
    problem: WindowProblem, task: DroneTask, stops: np.ndarray, pack: float = 0.0
) -> tuple[float, float]:
    """The route's exact energy, and its energy as the pool prices it: each loaded leg
    ``pack`` of the way to the full payload's energy per metre, the empty last leg as
    it is (docs/method.md §4.4, step 8)."""
    depots_xy = problem.depots_xy
    xy = problem.xy[stops]
    end = task.end if task.end >= 0 else int(nearest_depot(xy[-1], depots_xy)[0][0])
    pts = np.vstack([depots_xy[task.start], xy, depots_xy[end]])
    legs_m, legs_j = task.model.route_energy(pts, problem.weight[stops])
    exact = float(legs_j.sum())
    if pack <= 0:
        return exact, exact
    loaded = pack_priced(legs_j[:-1].sum(), legs_m[:-1].sum(), task.model, pack)
    return exact, float(loaded + legs_j[-1])
