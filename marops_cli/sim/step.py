"""One window step (docs/method.md §4): a day's state and the drones' actions -> the window's
plan -> the state after it.

Replay, plan-window, evaluate and the training environment all fly a window through
:func:`fly_window` (or plan it alone with :func:`plan_step`), with a :class:`WindowStep`
built once: so a policy is trained under the same scope, drone types and planner options
that replay later flies it with.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from ..config import OpsConfig, PlanConfig, PlannerConfig
from ..energy import EnergyModel
from ..errors import RunError
from ..plans.planner import Planner, make_planner
from ..plans.select import Selector, make_selector
from ..plans.view import EVERY_DEPOT, WindowView
from ..plans.window import WindowPlan, plan_routes
from ..policies.base import Policy, SlotActions
from ..policies.direct import SlotSelector
from .state import DayState

__all__ = ["WindowStep", "fly_window", "plan_step"]


@dataclass(frozen=True)
class WindowStep:
    """How a run flies its windows, the same for every window of every day."""

    model: EnergyModel
    """Prices delay (λ) and flies the drones of a one-type fleet; a mixed fleet's drones
    fly their own types' (the state's ``drone_models``)."""
    plan: PlanConfig
    """The plan settings, with the policy's own planner where it names one."""
    selector: Selector
    """Picks each drone's plan: the configured optimiser, or the slot selector of a policy
    that picks plans itself (the MAPPO baseline)."""
    scope: Literal["range", "global"] = "range"
    """``range``: the actions set the flight ranges; ``global``: the whole map."""
    ops: OpsConfig = field(default_factory=OpsConfig)
    """The operating model the windows are flown under (docs/method.md, "Operating
    model"); the default is the paper's."""
    planner: Planner = field(init=False, repr=False, compare=False)
    """Builds the drones' plans: chosen once, from ``plan`` and ``scope``."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "planner", make_planner(self.plan, self.scope))

    @classmethod
    def make(
        cls,
        cfg: PlannerConfig,
        *,
        scope: Literal["range", "global"] = "range",
        planner: str | None = None,
        selector: Selector | None = None,
        model: EnergyModel | None = None,
    ) -> WindowStep:
        """The step of ``cfg`` in ``scope``, flying ``planner``'s plans when it names one
        (else ``cfg``'s), chosen by ``selector`` (else ``cfg``'s), priced by ``model``
        (else ``cfg``'s ``[energy]``)."""
        plan = cfg.plan
        if planner is not None and planner != plan.planner:
            plan = plan.model_copy(update={"planner": planner})
        return cls(
            model or EnergyModel.of(cfg.energy),
            plan,
            selector or make_selector(cfg.plan),
            scope,
            cfg.ops,
        )

    @classmethod
    def of(
        cls,
        policy: Policy,
        cfg: PlannerConfig,
        *,
        model: EnergyModel | None = None,
        selector: Selector | None = None,
    ) -> WindowStep:
        """How ``policy`` flies under ``cfg``: its scope, its planner (the MAPPO baseline
        ranks the paper's subset plans) and its own selector where it brings one."""
        return cls.make(
            cfg,
            scope=policy.scope,
            planner=policy.planner,
            selector=selector or policy.selector,
            model=model,
        )

    def at_alpha(self, alpha: float) -> WindowStep:
        """This step at trade-off ``alpha`` (itself when it already is)."""
        if alpha == self.plan.alpha:
            return self
        plan = self.plan.model_copy(update={"alpha": alpha})
        return WindowStep(self.model, plan, self.selector, self.scope, self.ops)


def plan_step(view: WindowView, actions: np.ndarray | SlotActions, how: WindowStep) -> WindowPlan:
    """Plan window ``view.t`` with each drone's action (and, from a policy that picks plans
    itself, the plan slot it picked); nothing is applied."""
    selector = how.selector
    if isinstance(actions, SlotActions):
        if not isinstance(selector, SlotSelector):
            raise RunError("plan slots need the slot selector of the policy that picked them")
        selector = selector.picking(actions.slots)
        actions = actions.actions
    if how.ops.stock == "home" and (view.pending_stock == EVERY_DEPOT).any():
        # A view built without the model (one window planned alone): parcels wait at the
        # depot of their service area.
        view = replace(view, pending_stock=view.waiting_at())
    return plan_routes(view, actions, how.model, how.plan, selector, how.planner)


def fly_window(
    state: DayState,
    t: int,
    actions: np.ndarray | SlotActions,
    how: WindowStep,
    view: WindowView | None = None,
) -> WindowPlan:
    """Plan window ``t`` of ``state`` with ``actions`` and apply the plan: its stops are
    delivered and the drones land where their routes end. ``view`` is ``state.view(t)``
    when the caller has it already (the one the policy saw)."""
    state.operate(how.ops)
    plan = plan_step(state.view(t) if view is None else view, actions, how)
    state.apply(plan, how.model.speed_ms)
    return plan
