"""The flight-range policy protocol and the window view that policies read."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Literal, Protocol, runtime_checkable

import numpy as np

from ..plans.select import Selector
from ..plans.view import WindowView

if TYPE_CHECKING:
    from ..config import PlanConfig, PlannerConfig


@runtime_checkable
class Policy(Protocol):
    """Chooses each drone's destination among its depot's action candidates.

    ``scope`` is ``"range"`` for the paper's flight ranges and ``"global"`` for the
    whole-map baseline (the planner then ignores the actions). A policy that picks the
    plans itself (the MAPPO baseline) brings its ``selector`` and the ``planner`` whose
    plans it ranks; others leave both None. ``identity`` is what output files record
    (the actor file, or the policy's name).
    """

    name: str
    scope: Literal["range", "global"]
    planner: str | None
    selector: Selector | None

    @property
    def identity(self) -> str | Path: ...

    def configure(self, cfg: PlannerConfig) -> None:
        """Receive the run's planner settings (a policy that prices plans needs them)."""
        ...

    def reset(self, seed: int) -> None:
        """Start a new day (recurrent state, random streams)."""
        ...

    def act(self, view: WindowView) -> np.ndarray:
        """Action index (0 = stay) for every drone, shape ``(U,)``."""
        ...


class PolicyBase:
    """The protocol's defaults: a flight-range policy that needs no settings."""

    name: str = "policy"
    scope: Literal["range", "global"] = "range"
    planner: str | None = None
    selector: Selector | None = None

    @property
    def identity(self) -> str | Path:
        return self.name

    def configure(self, cfg: PlannerConfig) -> None:
        return None

    def reset(self, seed: int) -> None:
        return None


def start_day(policy: Policy, cfg: PlannerConfig, seed: int) -> None:
    """Hand a policy the run's planner settings and start its day."""
    policy.configure(cfg)
    policy.reset(seed)


def plan_config(policy: Policy, plan: PlanConfig) -> PlanConfig:
    """The plan settings ``policy`` flies with: its own ``planner`` when it names one (the
    MAPPO baseline ranks the paper's subset plans), else ``plan``."""
    if policy.planner is None or policy.planner == plan.planner:
        return plan
    return plan.model_copy(update={"planner": policy.planner})
