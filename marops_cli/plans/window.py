"""One window of planning (paper Alg. 2, improved): ranges -> candidates -> plans -> selection.

Two scopes (docs/method.md §7):

* ``range``: each drone's action picks its destination; its candidates are the
  M̂ most delayed pending requests inside its flight range.
* ``global`` (OPS-global): no flight range. The pool is the U·M̂ most delayed
  pending requests of the whole map; each drone's candidates are the M̂ of the
  pool nearest its depot; each plan lands at the depot nearest its last customer.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..config import PlanConfig
from ..energy import EnergyModel
from ..errors import RunError
from .objective import WindowScore, lam_j, score_routes
from .plans import PlanSet, build_plans
from .pool import DroneTask, build_pool, finish_route
from .ranges import pick_candidates
from .select import SelectionProblem, SelectionResult, Selector
from .view import FREE, WindowView


@dataclass
class DroneRoute:
    """The route one drone flies in one window; ``stops`` index the day's requests."""

    drone: int
    start: int
    end: int
    action: int
    stops: tuple[int, ...]
    legs_m: np.ndarray  # (len(stops) + 1,)
    legs_j: np.ndarray
    payload_kg: float  # at take-off

    @property
    def distance_m(self) -> float:
        return float(self.legs_m.sum())

    @property
    def energy_j(self) -> float:
        return float(self.legs_j.sum())


@dataclass
class WindowPlan:
    t: int
    routes: list[DroneRoute]
    selection: SelectionResult
    n_candidates: int
    timings: dict[str, float] = field(default_factory=dict)
    score: WindowScore | None = None
    """The window objective J and G of ``routes`` (docs/method.md)."""


def range_candidates(
    view: WindowView, rank: np.ndarray, rank_area: np.ndarray, s: int, a: int, m_hat: int
) -> np.ndarray:
    """Ĉ_u of a drone at depot ``s`` taking action ``a``: pending positions in its range.

    ``rank`` lists the pending requests by delay (highest first), then due time, and
    ``rank_area`` their areas, so only the head of the drone's range needs the full
    sort of :func:`pick_candidates` (with its distance tie-breaks): the first ``m_hat``
    requests and any tied with the last of them (on delay, and on due time when
    ``view.ties`` is ``"due"``).
    """
    inside = rank[view.ranges[s, a][rank_area]]
    if inside.size > m_hat:
        last, rest = inside[m_hat - 1], inside[m_hat:]
        tie = view.pending_delay_h[rest] == view.pending_delay_h[last]
        if view.ties == "due":
            tie &= view.pending_due_s[rest] == view.pending_due_s[last]
        inside = inside[: m_hat + (tie.size if tie.all() else int(np.argmin(tie)))]
    dist = np.hypot(*(view.pending_xy[inside] - view.depots.xy[s]).T)
    return pick_candidates(
        inside, view.pending_delay_h[inside], view.pending_due_s[inside], dist, m_hat, view.ties
    )


def drone_models(view: WindowView, model: EnergyModel) -> list[EnergyModel]:
    """Each drone's energy model: its type's (a mixed fleet), else ``model`` for all."""
    if view.drone_models is None:
        return [model] * view.n_drones
    if len(view.drone_models) != view.n_drones:
        raise RunError(f"{len(view.drone_models)} drone models for {view.n_drones} drones")
    return list(view.drone_models)


def _reachable_actions(
    view: WindowView, actions: np.ndarray, models: list[EnergyModel]
) -> np.ndarray:
    """Actions whose destination the empty drone cannot reach become 0 (stay); FREE stays
    FREE (an idle free drone stays where it is)."""
    dep = view.depots
    acts = np.asarray(actions, dtype=np.int64).copy()
    for u, s in enumerate(view.drone_depot):
        if acts[u] == FREE:
            continue
        d = int(dep.candidates[int(s), acts[u]])
        flight = float(np.hypot(*(dep.xy[d] - dep.xy[int(s)])))
        # The same test build_plans applies to the empty plan, so it never raises.
        if float(models[u].leg_energy_j(flight, 0.0)) > models[u].usable_j:
            acts[u] = 0
    return acts


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
        range_candidates(view, rank, rank_area, int(s), int(a), head)
        for s, a in zip(view.drone_depot, acts, strict=True)
    ]
    return draft(prefs, view.pending_idx.size, m_hat)


def draft(prefs: list[np.ndarray], n_items: int, m_hat: int) -> list[np.ndarray]:
    """Snake draft: in M̂ rounds (forward, then backward order) each drone claims its most
    preferred unclaimed item; then a drone left short tops up, in its own order, with
    items others claimed. ``prefs[u]`` lists drone u's items, most preferred first."""
    n_u = len(prefs)
    claimed = np.zeros(n_items, dtype=bool)
    picks: list[list[int]] = [[] for _ in range(n_u)]
    ptr = [0] * n_u
    for rnd in range(m_hat):
        for u in range(n_u) if rnd % 2 == 0 else range(n_u - 1, -1, -1):
            pref = prefs[u]
            while ptr[u] < pref.size and claimed[pref[ptr[u]]]:
                ptr[u] += 1
            if ptr[u] < pref.size:
                picks[u].append(int(pref[ptr[u]]))
                claimed[pref[ptr[u]]] = True
    out = []
    for u in range(n_u):
        mine = picks[u]
        if len(mine) < m_hat:
            taken = set(mine)
            mine = mine + [int(i) for i in prefs[u] if int(i) not in taken][: m_hat - len(mine)]
        out.append(np.array(mine, dtype=np.int64))
    return out


def _range_plans(
    view: WindowView, actions: np.ndarray, models: list[EnergyModel], cfg: PlanConfig
) -> tuple[list[PlanSet], np.ndarray, np.ndarray, float]:
    dep = view.depots
    acts = _reachable_actions(view, actions, models)
    t0 = time.perf_counter()
    rank = np.lexsort((view.pending_due_s, -view.pending_delay_h))
    rank_area = view.pending_area[rank]
    if cfg.candidates == "draft":
        cands = _drafted_candidates(view, rank, rank_area, acts, cfg.max_parcels)
    else:
        # Drones at the same depot taking the same action have the same candidates.
        by_key: dict[tuple[int, int], np.ndarray] = {}
        cands = []
        for u, s in enumerate(view.drone_depot):
            sa = (int(s), int(acts[u]))
            if sa not in by_key:
                by_key[sa] = range_candidates(view, rank, rank_area, *sa, cfg.max_parcels)
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
            done[key] = build_plans(
                dep.xy[s],
                dep.xy[dest],
                view.pending_xy[cand],
                view.pending_weight[cand],
                models[u],
                cfg,
                request_ids=cand,
            )
        plan_sets.append(done[key])
        ends[u] = dest
    return plan_sets, ends, acts, t_cand


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
    # Distance from every pooled request to every depot, and its nearest depot (ties to
    # the lower id), once for all drones.
    pxy = view.pending_xy[pool]
    d_pool = np.hypot(pxy[:, None, 0] - dep.xy[None, :, 0], pxy[:, None, 1] - dep.xy[None, :, 1])
    near = np.argmin(d_pool, axis=1)
    d_near = d_pool[np.arange(pool.size), near]
    # Each drone's pool positions, nearest its depot first (ties to the lower index).
    nearest = {int(s): np.lexsort((pool, d_pool[:, int(s)])) for s in set(view.drone_depot)}
    drafted = None
    if cfg.candidates == "draft":
        drafted = draft([nearest[int(s)] for s in view.drone_depot], pool.size, cfg.max_parcels)
    t_cand = time.perf_counter() - t0
    plan_sets, plan_ends = [], []
    done: dict[tuple[int, bytes, int], tuple[PlanSet, np.ndarray]] = {}  # same in, same out
    for u, s0 in enumerate(view.drone_depot):
        s, model = int(s0), models[u]
        e0 = float(model.energy_per_m(0.0))
        sel = nearest[s][: cfg.max_parcels] if drafted is None else drafted[u]
        key = (s, sel.tobytes(), id(model))
        if key in done:
            plan_sets.append(done[key][0])
            plan_ends.append(done[key][1])
            continue
        d = d_pool[:, s]
        cand = pool[sel]
        ps = build_plans(
            dep.xy[s],
            dep.xy[s],
            view.pending_xy[cand],
            view.pending_weight[cand],
            model,
            cfg,
            request_ids=cand,
        )
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


def _pool_tasks(
    view: WindowView,
    acts: np.ndarray,
    cfg: PlanConfig,
    scope: str,
    models: list[EnergyModel] | None = None,
) -> list[DroneTask]:
    """Each drone's start, end (-1: nearest depot to its last customer) and allowed requests."""
    dep = view.depots
    everything = np.arange(view.pending_idx.size, dtype=np.int64)
    tasks = []
    for u, s0 in enumerate(view.drone_depot):
        s = int(s0)
        m = None if models is None else models[u]
        if scope == "global":
            tasks.append(DroneTask(s, -1, everything, m))
            continue
        a = int(acts[u])
        free = a == FREE
        a = 0 if free else a
        dest = int(dep.candidates[s, a])
        if cfg.range == "areas":
            allowed = np.flatnonzero(view.ranges[s, a][view.pending_area]).astype(np.int64)
        else:  # the battery alone bounds what the drone can serve on its way
            allowed = everything
        fixed = cfg.landing == "destination" and not free
        tasks.append(DroneTask(s, dest if fixed else -1, allowed, m))
    return tasks


def _pool_plans(
    view: WindowView,
    acts: np.ndarray,
    model: EnergyModel,
    models: list[EnergyModel],
    cfg: PlanConfig,
    scope: str,
) -> tuple[list[PlanSet], list[np.ndarray], float]:
    """Route-pool plan sets (docs/method.md, "Route pool") and each plan's end depot;
    ``model`` prices delay (λ), ``models`` are the drones' own."""
    dep = view.depots
    t0 = time.perf_counter()
    tasks = _pool_tasks(view, acts, cfg, scope, models)
    lam = lam_j(cfg.alpha, model.usable_j)
    prize = lam * (1.0 + view.pending_delay_h)
    # Routes are built for the prize plus the urgency bonus; the selection judges them by
    # the window objective alone (docs/method.md §4.4).
    due = view.pending_due_w <= view.t
    search = prize + lam * cfg.pool_urgency * view.window_h * due if cfg.pool_urgency else prize
    res = build_pool(
        dep.xy,
        view.pending_xy,
        view.pending_weight,
        search,
        tasks,
        model,
        n_candidates=cfg.pool_candidates,
        iterations=cfg.pool_iterations,
        seed=view.t,
    )
    routes = [dict(zip(r, e, strict=True)) for r, e in zip(res.routes, res.energy_j, strict=True)]
    if cfg.pyvrp_iterations > 0:
        _add_pyvrp_routes(view, tasks, lam, model, cfg.pyvrp_iterations, routes)
    t_cand = time.perf_counter() - t0
    plan_sets, plan_ends = [], []
    for u, task in enumerate(tasks):
        empty_end = task.start if task.end < 0 else task.end
        flight = float(np.hypot(*(dep.xy[empty_end] - dep.xy[task.start])))
        keys = list(routes[u])
        ids = np.unique(np.array([i for k in keys for i in k], dtype=np.int64))
        n_k = len(keys) + 1
        members = np.zeros((n_k, ids.size), dtype=bool)
        order = np.full((n_k, max(ids.size, 1)), -1, dtype=np.int16)
        energy = np.empty(n_k)
        energy[0] = float(models[u].leg_energy_j(flight, 0.0))
        for k, key in enumerate(keys, start=1):
            col = np.searchsorted(ids, np.array(key, dtype=np.int64))
            members[k, col] = True
            order[k, : col.size] = col
            energy[k] = routes[u][key]
        weight = members @ view.pending_weight[ids] if ids.size else np.zeros(n_k)
        # Distances are recomputed for the chosen routes; the table needs energies only.
        plan_sets.append(PlanSet(ids, members, order, energy, np.zeros(n_k), weight))
        plan_ends.append(np.full(n_k, task.end, dtype=np.int64))
    return plan_sets, plan_ends, t_cand


def _add_pyvrp_routes(
    view: WindowView,
    tasks: list[DroneTask],
    lam: float,
    model: EnergyModel,
    iterations: int,
    routes: list[dict[tuple[int, ...], float]],
) -> None:
    """PyVRP's routes for the window as extra columns (each re-costed exactly)."""
    from .pyvrp_routes import solve_window

    n = view.pending_idx.size
    allowed = np.zeros((len(tasks), n), dtype=bool)
    for u, t in enumerate(tasks):
        allowed[u, t.allowed] = True
    ends = np.array([t.end for t in tasks], dtype=np.int64)
    peer = solve_window(
        view.depots.xy,
        np.array([t.start for t in tasks], dtype=np.int64),
        view.pending_xy,
        view.pending_weight,
        1.0 + view.pending_delay_h,
        lam,
        model,
        drone_end=None if np.all(ends < 0) else np.where(ends < 0, view.drone_depot, ends),
        allowed=None if allowed.all() else allowed,
        iterations=iterations,
        seed=view.t,
    )
    for s, stops in zip(peer.start, peer.stops, strict=True):
        for u, t in enumerate(tasks):
            if t.start != int(s) or not allowed[u, stops].all():
                continue
            own = t.model or model  # the drone's own limits (a mixed fleet)
            e = _route_energy_j(view, t, stops, own)
            w = float(view.pending_weight[stops].sum())
            if e <= own.usable_j and w <= own.max_payload_kg + 1e-9:
                routes[u].setdefault(tuple(int(i) for i in stops), e)


def _route_energy_j(
    view: WindowView, task: DroneTask, stops: np.ndarray, model: EnergyModel
) -> float:
    dep = view.depots
    xy = view.pending_xy[stops]
    end = task.end if task.end >= 0 else int(np.hypot(*(dep.xy - xy[-1]).T).argmin())
    pts = np.vstack([dep.xy[task.start], xy, dep.xy[end]])
    return float(model.route_energy(pts, view.pending_weight[stops])[1].sum())


def plan_window(
    view: WindowView,
    actions: np.ndarray,
    model: EnergyModel,
    cfg: PlanConfig,
    selector: Selector,
    scope: str = "range",
) -> WindowPlan:
    """Plan every drone's route for window ``view.t``; routes always respect payload,
    battery and the one-visit rule (checked before returning)."""
    t_start = time.perf_counter()
    acts = np.asarray(actions, dtype=np.int64)
    pool = cfg.planner == "pool"
    models = drone_models(view, model)
    if scope == "global":
        acts = np.zeros(view.n_drones, dtype=np.int64)
        if pool:
            plan_sets, plan_ends, t_cand = _pool_plans(view, acts, model, models, cfg, scope)
        else:
            plan_sets, plan_ends, t_cand = _global_plans(view, models, cfg)
    elif pool:
        acts = _reachable_actions(view, acts, models)
        plan_sets, plan_ends, t_cand = _pool_plans(view, acts, model, models, cfg, scope)
    else:  # the paper's planner has no free landing: FREE flies as stay
        acts = np.where(acts == FREE, 0, acts)
        plan_sets, ends, acts, t_cand = _range_plans(view, acts, models, cfg)
        plan_ends = [np.full(ps.n_plans, ends[u]) for u, ps in enumerate(plan_sets)]
    t_plans = time.perf_counter() - t_start - t_cand
    t0 = time.perf_counter()
    # The selection judges by the window objective itself (docs/method.md §4.4).
    delay = {int(i): float(view.pending_delay_h[i]) for ps in plan_sets for i in ps.request_ids}
    problem = SelectionProblem.from_plan_sets(
        plan_sets, delay, alpha=cfg.alpha, energy_ref_j=model.usable_j
    )
    t_problem = time.perf_counter() - t0  # the plan table is part of building the model
    sel = selector.select(problem)
    routes = []
    for u, ps in enumerate(plan_sets):
        k = int(sel.chosen[u])
        start, end = int(view.drone_depot[u]), int(plan_ends[u][k])
        stops_pos = ps.route(k)
        if pool and stops_pos:  # the energy-minimal order (and landing) of the chosen route
            xy = view.pending_xy[list(stops_pos)]
            fixed = None if end < 0 else view.depots.xy[end]
            order, near = finish_route(
                view.depots.xy[start],
                fixed,
                view.depots.xy,
                xy,
                view.pending_weight[list(stops_pos)],
                models[u],
            )
            stops_pos = tuple(stops_pos[i] for i in order)
            end = near if end < 0 else end
        elif end < 0:
            end = start
        pts = np.vstack(
            [
                view.depots.xy[start],
                view.pending_xy[list(stops_pos)].reshape(-1, 2),
                view.depots.xy[end],
            ]
        )
        w = view.pending_weight[list(stops_pos)]
        legs_m, legs_j = models[u].route_energy(pts, w)
        routes.append(
            DroneRoute(
                drone=u,
                start=start,
                end=end,
                action=int(acts[u]),
                stops=tuple(int(view.pending_idx[p]) for p in stops_pos),
                legs_m=np.asarray(legs_m),
                legs_j=np.asarray(legs_j),
                payload_kg=float(w.sum()),
            )
        )
    plan = WindowPlan(
        t=view.t,
        routes=routes,
        selection=sel,
        n_candidates=int(problem.request_ids.size),
        timings={
            "candidates": t_cand,
            "plans": t_plans,
            "build": t_problem + sel.build_s,
            "solve": sel.solve_s,
            "total": time.perf_counter() - t_start,
        },
    )
    check_routes(plan.routes, models)
    plan.score = score_routes(
        view.pending_idx,
        view.pending_delay_h,
        [(r.stops, r.energy_j) for r in plan.routes],
        lam_j(cfg.alpha, model.usable_j),
    )
    return plan


def check_routes(routes: list[DroneRoute], model: EnergyModel | list[EnergyModel]) -> None:
    """Raise :class:`RunError` if any route breaks payload, battery or one visit per order;
    ``model`` is every drone's, or a list of each drone's own (a mixed fleet)."""
    seen: set[int] = set()
    for r in routes:
        own = model[r.drone] if isinstance(model, list) else model
        if r.payload_kg > own.max_payload_kg + 1e-9:
            raise RunError(f"drone {r.drone}: payload {r.payload_kg:.3f} kg over the limit")
        if r.energy_j > own.usable_j + 1e-6:
            raise RunError(f"drone {r.drone}: energy {r.energy_j:.0f} J over the usable battery")
        for s in r.stops:
            if s in seen:
                raise RunError(f"order index {s} visited twice in one window")
            seen.add(s)
