"""Replay one day window by window with a fleet and a policy."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..config import PlannerConfig
from ..data.table import DayRequests
from ..energy import EnergyModel
from ..plans.window import WindowPlan
from ..policies.base import Policy, start_day
from ..segment.depots import Depots
from .state import DayState
from .step import WindowStep, fly_window


@dataclass
class FlownDay:
    method: str
    state: DayState
    plans: list[WindowPlan]
    runtime_s: float
    n_drones: int
    scope: str = "range"
    """The step's scope: under ``global`` every drone that flies lands freely."""


def fly_day(
    day: DayRequests,
    depots: Depots,
    drone_depot: np.ndarray,
    policy: Policy,
    cfg: PlannerConfig,
    *,
    method: str,
    how: WindowStep | None = None,
    on_window: Callable[[WindowPlan], None] | None = None,
    drone_models: Sequence[EnergyModel] | None = None,
) -> FlownDay:
    """Plan every window of ``day``; ``on_window`` is called after each (for progress).
    ``how`` flies the windows (default: as ``policy`` flies under ``cfg``);
    ``drone_models`` are each drone's own (a mixed fleet), None: the step's model for all."""
    how = how or WindowStep.of(policy, cfg)
    state = DayState(
        day,
        depots,
        drone_depot,
        cfg.plan.coverage,
        cfg.plan.ties,
        drone_models=drone_models,
        ops=how.ops,
        model=how.model,
    )
    start_day(policy, cfg, cfg.sim.seed)
    plans: list[WindowPlan] = []
    t0 = time.perf_counter()
    for t in range(day.n_windows):
        view = state.view(t)
        plan = fly_window(state, t, policy.act(view), how, view)
        plans.append(plan)
        if on_window is not None:
            on_window(plan)
    runtime = time.perf_counter() - t0
    return FlownDay(method, state, plans, runtime, int(len(drone_depot)), how.scope)
