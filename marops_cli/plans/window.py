"""One window of planning (paper Alg. 2, improved): ranges -> candidates -> plans -> selection.

The planner (``planner.py``, chosen once from the config) builds each drone's plans in
one of two scopes (docs/method.md §7): ``range``, each drone's action picks its
destination and flight range; ``global`` (OPS-global), no flight range. The selection
program then picks one plan per drone, and the chosen routes are checked.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..config import PlanConfig
from ..energy import EnergyModel
from ..errors import RunError
from .bound import BoundCaps, BoundResult, bound_g
from .objective import WindowScore, score_routes
from .planner import DronePlans, Planner, make_planner
from .plans import PlanSet
from .pool import finish_route
from .problem import Scope, WindowProblem
from .select import SelectionProblem, SelectionResult, Selector
from .view import WindowView

_BETTER_J = 1e-6  # a plan must gain more than this (J) to replace another


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
    bound: BoundResult | None = None
    """The proven upper bound on G (``PlanConfig.bound``; docs/method.md, "The bound")."""


def _drone_route(
    view: WindowView,
    u: int,
    route: tuple[tuple[int, ...], int],
    action: int,
    model: EnergyModel,
    reorder: bool,
) -> DroneRoute:
    """Drone ``u``'s route through ``route``'s stops (window positions) landing at its end
    (-1: the depot nearest its last stop); ``reorder``: in its energy-minimal order."""
    stops_pos, end = route
    start = int(view.drone_depot[u])
    if reorder and stops_pos:  # the energy-minimal order (and landing) of the route
        xy = view.pending_xy[list(stops_pos)]
        fixed = None if end < 0 else view.depots.xy[end]
        order, near = finish_route(
            view.depots.xy[start],
            fixed,
            view.depots.xy,
            xy,
            view.pending_weight[list(stops_pos)],
            model,
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
    legs_m, legs_j = model.route_energy(pts, w)
    return DroneRoute(
        drone=u,
        start=start,
        end=end,
        action=action,
        stops=tuple(int(view.pending_idx[p]) for p in stops_pos),
        legs_m=np.asarray(legs_m),
        legs_j=np.asarray(legs_j),
        payload_kg=float(w.sum()),
    )


def plan_routes(
    view: WindowView,
    actions: np.ndarray,
    model: EnergyModel,
    cfg: PlanConfig,
    selector: Selector,
    planner: Planner | Scope = "range",
) -> WindowPlan:
    """Plan every drone's route for window ``view.t``; routes always respect payload,
    battery and the one-visit rule (checked before returning).

    ``planner`` builds the plans, and the window's problem is built in its scope; a
    scope instead (``range`` or ``global``) is :func:`make_planner` of ``cfg`` in that
    scope. ``cfg.alpha`` and ``model`` price the selection either way.
    """
    t_start = time.perf_counter()
    if isinstance(planner, str):
        planner = make_planner(cfg, planner)
    acts = np.asarray(actions, dtype=np.int64)
    problem = WindowProblem.of(view, acts, model, cfg, planner.scope)
    return plan_problem(problem, view, selector, planner, cfg, t_start)


def plan_problem(
    problem: WindowProblem,
    view: WindowView,
    selector: Selector,
    planner: Planner,
    cfg: PlanConfig,
    t_start: float,
) -> WindowPlan:
    """:func:`plan_routes` of ``problem``, built from ``view`` (``t_start``: when the
    window's planning began, ``time.perf_counter``)."""
    models = problem.models
    made = planner.plans(problem, view)
    plan_sets, plan_ends, acts, t_cand = made.plan_sets, made.ends, made.actions, made.candidates_s
    t_plans = time.perf_counter() - t_start - t_cand
    t0 = time.perf_counter()
    # The selection judges by the window objective itself, with the night priced in the
    # day's last window (docs/method.md §4.4).
    sel_problem = SelectionProblem.of(plan_sets, problem.priced, problem.lam)
    t_problem = time.perf_counter() - t0  # the plan table is part of building the model
    sel = selector.select(sel_problem)
    sel = replace(sel, chosen=_canonical(view, plan_sets, plan_ends, sel.chosen, acts, models))
    routes = [
        _drone_route(
            view,
            u,
            (ps.route(int(sel.chosen[u])), int(plan_ends[u][int(sel.chosen[u])])),
            int(acts[u]),
            models[u],
            made.reorder,
        )
        for u, ps in enumerate(plan_sets)
    ]
    plan = WindowPlan(
        t=view.t,
        routes=routes,
        selection=sel,
        n_candidates=int(sel_problem.request_ids.size),
        timings={
            "candidates": t_cand,
            "plans": t_plans,
            "build": t_problem + sel.build_s,
            "solve": sel.solve_s,
            "total": time.perf_counter() - t_start,
        },
    )
    check_routes(plan.routes, models)
    plan.score = score_plan(view, plan.routes, problem.lam)
    if cfg.bound:  # warm-started with every plan the selection saw
        t0 = time.perf_counter()
        columns = [
            [(ps.route(k), float(ps.energy_j[k])) for k in range(1, ps.n_plans)] for ps in plan_sets
        ]
        plan.bound = bound_g(problem, columns=columns, caps=BoundCaps.of(cfg), plan=True)
        _take_bound_plan(plan, problem, view, made)
        plan.score = plan.score.with_bound(plan.bound.bound)
        plan.timings["bound"] = time.perf_counter() - t0
    return plan


def _canonical(
    view: WindowView,
    plan_sets: list[PlanSet],
    plan_ends: list[np.ndarray],
    chosen: np.ndarray,
    acts: np.ndarray,
    models: list[EnergyModel],
) -> np.ndarray:
    """The selection with its routes handed out in one order among interchangeable drones.

    Drones at the same depot with the same action and type may fly each other's routes
    at the same energy, so a program often has several optima that differ only in which
    of them flies which route; which one a solver returns depends on its path (HiGHS
    directly or through cvxpy, a relaxation's vertex). Where each of the group's routes
    is in every member's plans, the routes go to the drones in order of their stops, so
    the same routes give the same route files whichever optimum was found."""
    out = np.asarray(chosen, dtype=np.int64).copy()
    groups: dict[tuple[int, int, int], list[int]] = {}
    for u in range(len(plan_sets)):
        groups.setdefault((int(view.drone_depot[u]), int(acts[u]), id(models[u])), []).append(u)
    for members in groups.values():
        if len(members) < 2:
            continue
        picked = [
            (plan_sets[u].route(int(out[u])), int(plan_ends[u][int(out[u])])) for u in members
        ]
        index = [
            {(ps.route(k), int(plan_ends[u][k])): k for k in range(ps.n_plans)}
            for u, ps in ((u, plan_sets[u]) for u in members)
        ]
        if all(r in idx for r in picked for idx in index):
            for u, idx, r in zip(members, index, sorted(picked), strict=True):
                out[u] = idx[r]
    return out


def _take_bound_plan(
    plan: WindowPlan, problem: WindowProblem, view: WindowView, made: DronePlans
) -> None:
    """Fly the best plan over the bound's routes instead of the pool's when its G is
    higher (docs/method.md, "The bound"): the search priced far more routes than the
    pool holds, and the integer program over them often does better."""
    bound = plan.bound
    assert bound is not None and plan.score is not None
    if bound.plan is None or bound.plan_g <= plan.score.G + _BETTER_J:
        return
    models = problem.models
    # A drone without a route flies its pool's empty plan (the bound's empty route).
    routes = [
        _drone_route(
            view,
            u,
            (stops, int(end if stops else made.ends[u][0])),
            int(made.actions[u]),
            models[u],
            True,
        )
        for u, (stops, end) in enumerate(bound.plan)
    ]
    try:
        check_routes(routes, models)
    except RunError:
        return  # never fly a route that breaks a rule; the pool's plan stands
    score = score_plan(view, routes, problem.lam)
    if score.G > plan.score.G + _BETTER_J:
        plan.routes, plan.score = routes, score


def score_plan(view: WindowView, routes: list[DroneRoute], lam: float) -> WindowScore:
    """The window objective of ``routes`` over ``view``'s pending requests (λ ``lam``)."""
    return score_routes(
        view.pending_idx, view.pending_delay_h, [(r.stops, r.energy_j) for r in routes], lam
    )


def check_routes(routes: list[DroneRoute], model: EnergyModel | list[EnergyModel]) -> None:
    """Raise :class:`RunError` if any route breaks payload, battery or one visit per order;
    ``model`` is every drone's, or a list of each drone's own (a mixed fleet)."""
    seen: set[int] = set()
    for r in routes:
        own = model[r.drone] if isinstance(model, list) else model
        if not own.fits(r.payload_kg):
            raise RunError(f"drone {r.drone}: payload {r.payload_kg:.3f} kg over the limit")
        if not own.fits(energy_j=r.energy_j):
            raise RunError(f"drone {r.drone}: energy {r.energy_j:.0f} J over the usable battery")
        for s in r.stops:
            if s in seen:
                raise RunError(f"order index {s} visited twice in one window")
            seen.add(s)
