"""An upper bound on a window's objective G over every feasible route (docs/method.md,
"The bound").

The selection program picks one route per drone, each request at most once, from the
routes it is given. Over *all* feasible routes its linear relaxation

    max Σ_k (G_k − G_∅) x_k + Σ_d n_d G_∅d
    s.t. Σ_{k of class d} x_k ≤ n_d   (identical drones: a class of n_d)
         Σ_k a_ik x_k ≤ 1            (each request)
         x ≥ 0

bounds the best plan any planner can fly (G_k = λ Σ_{i∈k} v_i − E_k; G_∅ is the empty
route's). It is solved by column generation: the master over the routes found so far
(first the planner's own) gives request prices π ≥ 0, and the pricing
(:mod:`.pricing`) looks for a route of positive reduced cost. Any π ≥ 0 proves

    G ≤ Σ_d n_d G_∅d + Σ_i π_i + Σ_d n_d · max(0, U_d)

with U_d ≥ max_k (Σ_{i∈k} (λ v_i − π_i) − E_k + E_∅d) over drone class d's routes
(Lagrangian relaxation of the request rows); every pricing returns such a U_d, the
route it found when its search was complete, an upper bound on what it left out
otherwise. The lowest value is the bound. Before the first pricing the bound is the
trivial Σ λ v_i over the requests some drone can serve less every drone's least
energy (its empty route's: no route flies less).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import highspy
import numpy as np
from numpy.typing import NDArray

from ..config import BOUND_LABELS, PlanConfig
from ..energy import EnergyModel
from ..segment.depots import nearest_depot
from . import pricing
from .highs import new_highs, run_highs
from .pricing import DroneClass, price
from .problem import WindowProblem
from .view import WindowView

__all__ = ["BoundCaps", "BoundResult", "bound_g", "window_bound"]

_RC_TOL = 1e-6  # a reduced cost (J) above this is worth a column
_REL_STOP = 1e-5  # stop once the bound is this close (relative) to the master's value
_KEEP = 3  # labels per node a heuristic pricing extends
MAX_WORK = BOUND_LABELS
"""Labels a bound makes at most by default (``[plan] bound_labels``)."""
MAX_LABELS = 20_000
"""Labels of one length a full pricing keeps at most by default (a 25th of ``MAX_WORK``;
``[plan] bound_labels`` raises both)."""


@dataclass(frozen=True)
class BoundCaps:
    """What a bound's search may spend (:func:`bound_g`); a capped search still returns a
    valid bound and says which cap it hit."""

    ng: int = 8
    """The ng-neighbourhood size (≥ the requests: elementary routes)."""
    max_work: int = MAX_WORK
    """Work in all: labels made, a label of a pricing over more than ``pricing.WIDE``
    requests counting in proportion (a wide pricing stops short of it)."""
    time_limit_s: float | None = None
    """CPU seconds; None: no clock (the default), so that the bound is the same on any
    machine."""
    max_iterations: int = 200
    """Pricing rounds."""
    max_labels: int = MAX_LABELS
    """Labels of one length in a full pricing."""

    @classmethod
    def of(cls, cfg: PlanConfig, **caps: float) -> BoundCaps:
        """The caps ``cfg`` sets (``max_work`` is ``cfg.bound_labels`` and ``max_labels`` a
        25th of it, at least ``MAX_LABELS``), with ``caps`` overriding them."""
        caps.setdefault("max_work", cfg.bound_labels)
        caps.setdefault("max_labels", max(MAX_LABELS, cfg.bound_labels // 25))
        return cls(**caps)  # type: ignore[arg-type]


@dataclass(frozen=True)
class BoundResult:
    """An upper bound on G and how it was found."""

    bound: float
    """Upper bound on G (J): the lowest valid bound found."""
    lp: float
    """The master program's value at the last solve (a lower bound on the relaxation)."""
    converged: bool
    """The bound met the master's value: ``bound`` is the relaxation's value (over
    ng-routes)."""
    priced: bool
    """``bound`` comes from a pricing round; False: the trivial bound (a cap was hit
    before the first round)."""
    capped: str
    """Which cap stopped the search short of the relaxation's value ("" when none):
    "work" (``max_work`` of work done, or a wide pricing or class stopped by it),
    "requests" (a drone class may serve more than ``pricing.MAX_PRICED`` requests and
    is bounded by its knapsack), "time", "iterations", or "labels" (a full pricing, cut
    by ``max_labels``, found nothing more to add)."""
    iterations: int
    columns: int
    cpu_s: float
    labels: int = 0
    """Labels the pricings made."""
    work: int = 0
    """The work done, the same on any machine: labels, each counted ``max(1, m /
    pricing.WIDE)`` in a pricing over ``m`` requests, and a wide pricing's tables."""
    plan: tuple[tuple[tuple[int, ...], int], ...] | None = None
    """The best plan over the routes the search found, when asked for with ``plan=True``:
    per task its stops (window positions, in visiting order; none: the task's empty
    route) and its landing (-1: the depot nearest the last stop)."""
    plan_g: float = -np.inf
    """G of ``plan``."""


class _Master:
    """The restricted master program in HiGHS (minimising −G, every row "≤")."""

    def __init__(self, counts: Sequence[int], n_req: int) -> None:
        self.h = new_highs()
        self.n_cls, self.n_req = len(counts), n_req
        n_rows = self.n_cls + n_req
        upper = np.concatenate([np.asarray(counts, dtype=np.float64), np.ones(n_req)])
        self.h.addRows(
            n_rows,
            np.full(n_rows, -highspy.kHighsInf),
            upper,
            0,
            np.zeros(n_rows, dtype=np.int32),
            np.zeros(0, dtype=np.int32),
            np.zeros(0),
        )
        self.keys: dict[tuple[int, tuple[int, ...]], float] = {}
        self.cols: list[tuple[int, tuple[int, ...], float]] = []
        """Each column: its class, stops in visiting order and G − G_∅."""
        self.value = -np.inf

    def add(self, cols: list[tuple[int, tuple[int, ...], float]]) -> int:
        """Add columns (class, stops, G − G_∅), each set of stops once in its best order
        known; returns how many were new."""
        cost: list[float] = []
        starts: list[int] = []
        index: list[int] = []
        vals: list[float] = []
        for c, stops, g in cols:
            key = (c, tuple(sorted(stops)))
            if self.keys.get(key, -np.inf) >= g - _RC_TOL:
                continue  # known, in an order at least as good
            self.keys[key] = g
            self.cols.append((c, tuple(stops), g))
            req, cnt = np.unique(np.asarray(stops, dtype=np.int64), return_counts=True)
            starts.append(len(index))
            index += [c, *(self.n_cls + req).tolist()]
            vals += [1.0, *cnt.astype(np.float64).tolist()]
            cost.append(-g)
        n = len(cost)
        if n:
            self.h.addCols(
                n,
                np.array(cost),
                np.zeros(n),
                np.full(n, highspy.kHighsInf),
                len(index),
                np.array(starts, dtype=np.int32),
                np.array(index, dtype=np.int32),
                np.array(vals),
            )
        return n

    def solve(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Solve; the value (of G − Σ n_d G_∅d) and the duals: (drone μ, request π) ≥ 0."""
        if not self.keys:  # no route yet: nothing to price against
            self.value = 0.0
            return np.zeros(self.n_cls), np.zeros(self.n_req)
        run_highs(self.h)
        if self.h.getModelStatus() != highspy.HighsModelStatus.kOptimal:
            raise RuntimeError(f"master program: {self.h.getModelStatus().name}")
        self.value = -float(self.h.getInfo().objective_function_value)
        dual = np.maximum(-np.asarray(self.h.getSolution().row_dual, dtype=np.float64), 0.0)
        return dual[: self.n_cls], dual[self.n_cls :]


def _classes(
    problem: WindowProblem, ng: int, max_work: float
) -> tuple[list[DroneClass], list[int], float]:
    """Identical drones as one class; each task's class; the work their tables took.

    A class of ``n`` > ``pricing.WIDE`` requests counts ``n · n / WIDE`` for its tables
    (as many entries as a level of its labels scans); once that passes ``max_work`` the
    remaining wide classes are made without them, and are not priced."""
    req_xy = np.asarray(problem.xy, dtype=np.float64)
    depots_xy = np.asarray(problem.depots_xy, dtype=np.float64)
    land_m = nearest_depot(req_xy, depots_xy)[1] if len(req_xy) else np.zeros(0)
    keys: dict[tuple[int, int, bytes, int], int] = {}
    members: list[list[int]] = []
    of: list[int] = []
    for u, t in enumerate(problem.tasks):
        k = (t.start, t.end, np.asarray(t.allowed, dtype=np.int64).tobytes(), id(t.model))
        if k not in keys:
            keys[k] = len(members)
            members.append([])
        members[keys[k]].append(u)
        of.append(keys[k])
    classes: list[DroneClass] = []
    work = 0.0
    for us in members:
        task = problem.tasks[us[0]]
        n = int(np.asarray(task.allowed).size)
        cost = n * n / pricing.WIDE if n > pricing.WIDE else 0.0
        fits = work + cost <= max_work
        work += cost if fits else 0.0
        classes.append(DroneClass.of(task, problem, land_m, len(us), ng, tables=fits))
    return classes, of, work


def bound_g(
    problem: WindowProblem,
    *,
    columns: Sequence[Sequence[tuple[Sequence[int], float]]] | None = None,
    caps: BoundCaps = BoundCaps(),  # noqa: B008 (frozen)
    plan: bool = False,
) -> BoundResult:
    """An upper bound on G for ``problem``'s drones (module docstring), its prizes
    ``problem.prize`` (λ v_i per pending position).

    ``columns`` each task's known routes as ``(positions, energy J)`` (the planner's
    pool: a warm start); ``caps`` what the search may spend. ``plan``: also the best
    plan over the routes found (an integer program over the master's elementary routes).
    """
    c0 = time.process_time()
    prize = np.asarray(problem.prize, dtype=np.float64)
    max_work, max_labels = caps.max_work, caps.max_labels
    classes, of, setup = _classes(problem, caps.ng, max_work)
    const = -sum(c.count * c.e_empty for c in classes)
    servable = np.zeros(prize.size, dtype=bool)
    for c in classes:
        servable[c.pos] = True
    trivial = const + float(prize[servable].sum())
    master = _Master([c.count for c in classes], prize.size)
    warm = []
    for u, routes in enumerate(columns or []):
        c = classes[of[u]]
        for stops, e in routes:
            if len(stops):
                warm.append(
                    (
                        of[u],
                        tuple(int(s) for s in stops),
                        float(prize[list(stops)].sum()) - float(e) + c.e_empty,
                    )
                )
    master.add(warm)
    best, priced, converged, capped, it = trivial, False, False, "", 0
    heuristic, full_done = True, False
    lp, work, labels = -np.inf, setup, 0
    clock = np.inf if caps.time_limit_s is None else float(caps.time_limit_s)
    while True:
        mu, pi = master.solve()
        lp = master.value + const
        if work > max_work:
            capped = "work"
            break
        if time.process_time() - c0 > clock:
            capped = "time"
            break
        if it >= caps.max_iterations:
            capped = "iterations"
            break
        it += 1
        profit = prize - pi
        new, tops, exact, cut = [], [], True, ""
        for k, c in enumerate(classes):
            late = max_work - work if time.process_time() - c0 <= clock else 0
            pr = price(
                c,
                profit,
                float(mu[k]) + _RC_TOL,
                keep=_KEEP if heuristic else None,
                max_labels=max_labels,
                budget=late,
                limit=max_work - work,
            )
            work += pr.work
            labels += pr.labels
            exact &= pr.exact
            cut = cut or pr.cut
            tops.append(max(pr.ub, 0.0))
            new += [(k, s, float(prize[list(s)].sum()) - e + c.e_empty) for s, e, _ in pr.routes]
        # The master's own columns count too: a known route outside the drones' tasks
        # (another planner's) is then covered as well.
        for k, stops, g in master.cols:
            tops[k] = max(tops[k], g - float(pi[list(stops)].sum()))
        # Every pricing bounds every route's value: a valid bound (Lagrangian relaxation).
        lagr = (
            const + float(pi.sum()) + sum(c.count * t for c, t in zip(classes, tops, strict=True))
        )
        best, priced = min(best, lagr), True
        added = master.add(new)
        if best - lp <= _REL_STOP * max(abs(best), 1.0):
            converged = True
            break
        if cut:  # a pricing stopped short of its work limit or its class's size
            capped = cut
            break
        if added == 0 and not heuristic:
            capped = "" if exact else "labels"
            break  # the full pricing found nothing to add: no better bound within reach
        # A heuristic round that found nothing is followed by a full one, which is
        # followed by heuristic rounds again when it found columns.
        heuristic = added > 0
        half = work > 0.5 * max_work or time.process_time() - c0 > 0.5 * clock
        if heuristic and not full_done and half:
            heuristic = False  # half the budget gone: one full round, for a tighter bound
        full_done |= not heuristic
    best_plan, best_g = _best_plan(master, classes, of, const) if plan else (None, -np.inf)
    return BoundResult(
        bound=best,
        lp=lp,
        converged=converged,
        priced=priced,
        capped="" if converged else capped,
        iterations=it,
        columns=len(master.keys),
        cpu_s=time.process_time() - c0,
        labels=labels,
        work=round(work),
        plan=best_plan,
        plan_g=best_g,
    )


_PLAN_NODES = 2_000  # branch-and-bound nodes of the best-plan program: a count, not a clock


def _best_plan(
    master: _Master,
    classes: list[DroneClass],
    of: list[int],
    const: float,
) -> tuple[tuple[tuple[tuple[int, ...], int], ...], float]:
    """The best plan over the master's elementary routes (each request at most once, at
    most a class's count of routes per class), each route given to a drone of its
    class: ``BoundResult.plan`` and ``plan_g``. The master's own program, with only
    elementary routes of positive value allowed and every column integral."""
    routes: list[tuple[tuple[int, ...], int]] = [((), classes[c].end) for c in of]
    fly = [len(set(st)) == len(st) and g > 0 for _, st, g in master.cols]
    if not any(fly):
        return tuple(routes), const
    lp = master.h.getLp()
    lp.col_upper_ = np.asarray(fly, dtype=np.float64)
    lp.integrality_ = [highspy.HighsVarType.kInteger] * lp.num_col_
    h = new_highs()
    h.setOptionValue("mip_max_nodes", _PLAN_NODES)
    h.passModel(lp)
    run_highs(h)
    if h.getInfo().primal_solution_status != highspy.kSolutionStatusFeasible:
        return tuple(routes), const
    x = np.asarray(h.getSolution().col_value, dtype=np.float64)
    free = {c: [u for u in range(len(of)) if of[u] == c] for c in range(len(classes))}
    g = const
    for k in np.flatnonzero(x > 0.5):
        c, st, gk = master.cols[int(k)]
        routes[free[c].pop(0)] = (st, classes[c].end)
        g += gk
    return tuple(routes), g


def window_bound(
    view: WindowView,
    actions: NDArray[np.int64],
    model: EnergyModel,
    cfg: PlanConfig,
    *,
    relaxed: bool = False,
    **caps: float,
) -> BoundResult:
    """The bound of one window for the drones' ``actions`` as the route pool flies them
    in flight ranges (``cfg`` decides each drone's landing and allowed requests; λ from
    ``cfg.alpha`` and ``model``'s usable battery): :func:`bound_g` of
    :meth:`WindowProblem.of`.

    ``relaxed``: every drone that can fly lands freely and may serve whatever its depot
    stocks (:meth:`WindowProblem.relaxed`): a bound on every planner's plan, whatever
    its actions (a free landing never costs more than a fixed one). ``caps``:
    :class:`BoundCaps`' fields (:meth:`BoundCaps.of` ``cfg``) and ``plan``.
    """
    problem = WindowProblem.of(view, actions, model, cfg)
    plan = bool(caps.pop("plan", False))
    return bound_g(
        problem.relaxed() if relaxed else problem, caps=BoundCaps.of(cfg, **caps), plan=plan
    )
