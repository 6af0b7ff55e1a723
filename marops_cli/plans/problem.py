"""The window problem: what every planner, bound and pricing of one window reads.

A :class:`WindowProblem` is built once per window (:meth:`WindowProblem.of`) from the
view, the plan config and the fleet, and the route pool, the bound, its pricing, the
PyVRP mapping, the selection and the objective take it (docs/decisions.md,
"Architecture"). It holds the depots, the pending requests (where, how heavy, their
value v = 1 + delay and where each is stocked), λ, and one :class:`DroneTask` per drone
carrying the drone's own energy model and the requests it may serve. What the view
leaves unset (one drone type, parcels at every depot, every drone able to fly) is filled
in here as values, so that nothing downstream asks again.

λ = ((1 − α)/α) · E_ref is derived here, once per window (:func:`.objective.lam_j`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..config import PlanConfig
from ..energy import EnergyModel
from ..errors import RunError
from .objective import lam_j, priced_delay_h, wait_credit_j
from .view import EVERY_DEPOT, FREE, WindowView

__all__ = [
    "EVERY_DEPOT",
    "DroneTask",
    "Scope",
    "WindowProblem",
    "can_reach",
    "drone_models",
    "flown_actions",
    "pricing_delay_h",
]

Scope = Literal["range", "global"]


_NONE = np.zeros(0, dtype=np.int64)


@dataclass(frozen=True)
class DroneTask:
    """What one drone may do in the window."""

    start: int
    """Start depot id."""
    end: int
    """Fixed end depot id, or -1: land at the depot nearest the last customer."""
    allowed: NDArray[np.int64]
    """Positions (in the window's pending arrays) of the requests it may serve."""
    model: EnergyModel
    """The drone's own energy model (its type: payload, battery, speed)."""


@dataclass(frozen=True)
class WindowProblem:
    """One window's planning problem (module docstring); positions index the pending
    requests of the window."""

    depots_xy: NDArray[np.float64]
    """``(N, 2)`` metres."""
    xy: NDArray[np.float64]
    """``(P, 2)`` the pending requests, metres."""
    weight: NDArray[np.float64]
    """``(P,)`` kilograms."""
    delay_h: NDArray[np.float64]
    """``(P,)`` each request's delay (hours): v = 1 + delay (:attr:`value`)."""
    lam: float
    """λ = ((1 − α)/α) · E_ref (J per unit of v left unserved)."""
    tasks: tuple[DroneTask, ...]
    """One per drone, each with its own energy model."""
    model: EnergyModel
    """The model that prices delay (E_ref is its usable battery) and PyVRP's costs."""
    stock: NDArray[np.int64]
    """``(P,)`` the depot each parcel is stocked at (:data:`EVERY_DEPOT`: all of them)."""
    ready: NDArray[np.bool_]
    """``(U,)`` whether each drone can fly this window."""
    actions: NDArray[np.int64]
    """``(U,)`` the actions flown: out of reach or grounded become 0 (stay); FREE stays
    FREE; all 0 in the ``global`` scope."""
    priced_h: NDArray[np.float64]
    """``(P,)`` the delay the route pool and the selection price each request at
    (docs/method.md §4.4: the night and the wait credit; the paper's planner: the delay)."""
    search: NDArray[np.float64]
    """``(P,)`` the prize (J) the route pool builds its routes for: λ times the priced
    value, plus the urgency bonus."""
    t: int = 0
    """The window (it seeds the pool's and PyVRP's searches)."""

    @classmethod
    def of(
        cls,
        view: WindowView,
        actions: NDArray[np.int64],
        model: EnergyModel,
        cfg: PlanConfig,
        scope: Scope = "range",
    ) -> WindowProblem:
        """The problem of window ``view.t`` with the drones flying ``actions`` as the
        route pool flies them (``scope`` and ``cfg`` decide each drone's landing and
        allowed requests); λ from ``cfg.alpha`` and ``model``'s usable battery."""
        models = drone_models(view)
        stock = np.asarray(view.pending_stock, dtype=np.int64)
        ready = np.asarray(view.drone_ready, dtype=bool)
        if stock.shape != view.pending_idx.shape or ready.shape != view.drone_depot.shape:
            raise RunError(
                f"a view of {view.pending_idx.size} requests and {view.n_drones} drones "
                f"with {stock.size} stock depots and {ready.size} ready flags"
            )
        acts = flown_actions(view, actions, models, scope)
        lam = lam_j(cfg.alpha, model.usable_j)
        delay = np.asarray(view.pending_delay_h, dtype=np.float64)
        priced = pricing_delay_h(view, cfg, model, lam)
        prize = lam * (1.0 + priced)
        # Routes are built for the prize plus the urgency bonus; the selection judges them
        # by the window objective alone (docs/method.md §4.4).
        due = view.pending_due_w <= view.t
        search = prize + lam * cfg.pool_urgency * view.window_h * due if cfg.pool_urgency else prize
        problem = cls(
            depots_xy=view.depots.xy,
            xy=view.pending_xy,
            weight=view.pending_weight,
            delay_h=delay,
            lam=lam,
            tasks=(),
            model=model,
            stock=stock,
            ready=ready,
            actions=acts,
            priced_h=priced,
            search=search,
            t=view.t,
        )
        return replace(problem, tasks=_tasks(problem, view, cfg, scope, models))

    @classmethod
    def of_requests(
        cls,
        depots_xy: NDArray[np.float64],
        xy: NDArray[np.float64],
        weight: NDArray[np.float64],
        delay_h: NDArray[np.float64],
        lam: float,
        tasks: list[DroneTask],
    ) -> WindowProblem:
        """A problem over given requests and tasks, without a view: every parcel at every
        depot, every drone able to fly, each request priced at its delay, the pool's prize
        λ · v; the first task's model prices delay."""
        delay = np.asarray(delay_h, dtype=np.float64)
        n_u = len(tasks)
        return cls(
            depots_xy=np.asarray(depots_xy, dtype=np.float64),
            xy=np.asarray(xy, dtype=np.float64),
            weight=np.asarray(weight, dtype=np.float64),
            delay_h=delay,
            lam=float(lam),
            tasks=tuple(tasks),
            model=tasks[0].model,
            stock=np.full(delay.size, EVERY_DEPOT, np.int64),
            ready=np.ones(n_u, dtype=bool),
            actions=np.zeros(n_u, dtype=np.int64),
            priced_h=delay,
            search=lam * (1.0 + delay),
        )

    @property
    def n_drones(self) -> int:
        return len(self.tasks)

    @property
    def n_requests(self) -> int:
        return int(self.weight.shape[0])

    @property
    def models(self) -> list[EnergyModel]:
        """Each drone's energy model."""
        return [t.model for t in self.tasks]

    @cached_property
    def value(self) -> NDArray[np.float64]:
        """``(P,)`` v = 1 + delay (hours): what serving each request is worth, in units of λ."""
        return 1.0 + self.delay_h

    @cached_property
    def prize(self) -> NDArray[np.float64]:
        """``(P,)`` λ · v (J): the objective's prize for serving each request."""
        return self.lam * self.value

    @cached_property
    def priced(self) -> NDArray[np.float64]:
        """``(P,)`` v as the route pool and the selection price it: 1 + :attr:`priced_h`."""
        return 1.0 + self.priced_h

    @cached_property
    def stocked_everywhere(self) -> bool:
        """Every parcel at every depot (the paper)."""
        return bool((self.stock == EVERY_DEPOT).all())

    def stocked_at(self, s: int) -> NDArray[np.int64] | None:
        """Positions a drone departing from depot ``s`` may carry; None: every one."""
        if self.stocked_everywhere:
            return None
        return np.flatnonzero((self.stock == s) | (self.stock == EVERY_DEPOT)).astype(np.int64)

    def relaxed(self) -> WindowProblem:
        """This problem with every drone that can fly landing freely and serving whatever
        its depot stocks (the ``global`` scope's tasks): its bound holds for every plan,
        whatever the drones' actions."""
        everything = np.arange(self.n_requests, dtype=np.int64)
        tasks = []
        for u, task in enumerate(self.tasks):
            s = task.start
            if not self.ready[u]:
                tasks.append(DroneTask(s, s, _NONE, task.model))
                continue
            stocked = self.stocked_at(s)
            tasks.append(DroneTask(s, -1, everything if stocked is None else stocked, task.model))
        return replace(self, tasks=tuple(tasks), actions=np.zeros(self.n_drones, np.int64))


def drone_models(view: WindowView) -> list[EnergyModel]:
    """Each drone's energy model, its type's (one per drone, checked)."""
    if len(view.drone_models) != view.n_drones:
        raise RunError(f"{len(view.drone_models)} drone models for {view.n_drones} drones")
    return list(view.drone_models)


def can_reach(view: WindowView, u: int, action: int, model: EnergyModel) -> bool:
    """Whether drone ``u`` (energy ``model``) reaches its action's destination empty."""
    dep = view.depots
    s = int(view.drone_depot[u])
    d = int(dep.candidates[s, action])
    flight = float(np.hypot(*(dep.xy[d] - dep.xy[s])))
    # The same test build_plans applies to the empty plan, so it never raises.
    return float(model.leg_energy_j(flight, 0.0)) <= model.usable_j


def flown_actions(
    view: WindowView, actions: NDArray[np.int64], models: list[EnergyModel], scope: Scope
) -> NDArray[np.int64]:
    """The actions the drones fly: in the ``global`` scope all 0 (no flight range);
    else a destination the empty drone cannot reach becomes 0 (stay), FREE stays FREE
    (an idle free drone stays where it is), and a drone that cannot fly this window
    (docs/method.md, "Operating model") stays."""
    if scope == "global":
        return np.zeros(view.n_drones, dtype=np.int64)
    acts = np.asarray(actions, dtype=np.int64).copy()
    for u in range(view.n_drones):
        if acts[u] != FREE and not can_reach(view, u, int(acts[u]), models[u]):
            acts[u] = 0
    return np.where(view.drone_ready, acts, 0)


def pricing_delay_h(
    view: WindowView, cfg: PlanConfig, model: EnergyModel, lam: float
) -> NDArray[np.float64]:
    """The delay (hours) each pending request is priced at when the route pool builds and
    chooses plans (docs/method.md §4.4, "What waiting saves" and "The day's end"): its
    delay; plus, in hours of λ, the energy waiting would not save (``[plan]
    wait_credit`` times its cheapest detour, :func:`wait_credit_j`); plus, in the day's
    last window, the night a parcel left then waits (``[plan] night_h``; None: 24 h less
    the service hours); plus, in every window, ``[plan] serve_h``. The paper's planner
    prices the delay alone. At α = 1 (λ = 0: energy alone counts) the wait credit has
    no hours to be counted in and is left out: a delay priced at infinity would make
    every prize λ · v not a number."""
    delay = np.asarray(view.pending_delay_h, dtype=np.float64)
    if cfg.planner != "pool":
        return delay
    night = cfg.night_h
    if night is None:
        night = max(0.0, 24.0 - view.n_windows * view.window_h)
    priced = priced_delay_h(delay, view.t == view.n_windows - 1, night)
    if cfg.wait_credit > 0 and delay.size and lam > 0:
        credit = wait_credit_j(view.pending_xy, view.depots.xy, float(model.energy_per_m(0.0)))
        priced = priced + cfg.wait_credit * credit / lam
    return priced + cfg.serve_h if cfg.serve_h > 0 else priced


def _tasks(
    problem: WindowProblem,
    view: WindowView,
    cfg: PlanConfig,
    scope: Scope,
    models: list[EnergyModel],
) -> tuple[DroneTask, ...]:
    """Each drone's start, end (-1: nearest depot to its last customer) and allowed
    requests as the route pool flies ``problem.actions``."""
    dep = view.depots
    everything = np.arange(problem.n_requests, dtype=np.int64)
    tasks = []
    for u, s0 in enumerate(view.drone_depot):
        s, m = int(s0), models[u]
        if not problem.ready[u]:  # it stays: no request, its own depot
            tasks.append(DroneTask(s, s, _NONE, m))
            continue
        stocked = problem.stocked_at(s)
        if scope == "global":
            tasks.append(DroneTask(s, -1, everything if stocked is None else stocked, m))
            continue
        a = int(problem.actions[u])
        free = a == FREE
        a = 0 if free else a
        dest = int(dep.candidates[s, a])
        if cfg.range == "areas":
            allowed = np.flatnonzero(view.ranges[s, a][view.pending_area]).astype(np.int64)
        else:  # the battery alone bounds what the drone can serve on its way
            allowed = everything
        if stocked is not None:
            allowed = np.intersect1d(allowed, stocked)
        fixed = cfg.landing == "destination" and not free
        tasks.append(DroneTask(s, dest if fixed else -1, allowed, m))
    return tuple(tasks)
