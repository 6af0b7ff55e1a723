"""The flight-range policy protocol and the window view that policies read."""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal, Protocol, runtime_checkable

import numpy as np

from ..plans.view import WindowView

if TYPE_CHECKING:
    from ..config import PlanConfig, PlannerConfig


@runtime_checkable
class Policy(Protocol):
    """Chooses each drone's destination among its depot's action candidates.

    ``scope`` is ``"range"`` for the paper's flight ranges and ``"global"`` for the
    whole-map baseline (the planner then ignores the actions).
    """

    name: str
    scope: Literal["range", "global"]

    def reset(self, seed: int) -> None:
        """Start a new day (recurrent state, random streams)."""
        ...

    def act(self, view: WindowView) -> np.ndarray:
        """Action index (0 = stay) for every drone, shape ``(U,)``."""
        ...


def start_day(policy: Policy, cfg: PlannerConfig, seed: int) -> None:
    """Hand a policy the run's planner settings, if it plans ahead (``configure``), and
    start its day (``reset``)."""
    configure = getattr(policy, "configure", None)
    if configure is not None:
        configure(cfg)
    policy.reset(seed)


def plan_config(policy: object, plan: PlanConfig) -> PlanConfig:
    """The plan settings ``policy`` flies with: a policy that picks plans itself (the MAPPO
    baseline, trained on the paper's subsets) names its ``planner``; others use ``plan``."""
    planner = getattr(policy, "planner", None)
    if planner is None or planner == plan.planner:
        return plan
    return plan.model_copy(update={"planner": planner})
