"""Replay one day window by window with a fleet, a policy and a selector."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..config import PlannerConfig
from ..data.table import DayRequests
from ..energy import EnergyModel
from ..plans.select import Selector, make_selector
from ..plans.window import WindowPlan, plan_window
from ..policies.base import Policy, plan_config, start_day
from ..segment.depots import Depots
from .state import DayState


@dataclass
class DayResult:
    method: str
    state: DayState
    plans: list[WindowPlan]
    runtime_s: float
    n_drones: int


def replay_day(
    day: DayRequests,
    depots: Depots,
    drone_depot: np.ndarray,
    policy: Policy,
    cfg: PlannerConfig,
    *,
    method: str,
    model: EnergyModel | None = None,
    selector: Selector | None = None,
    on_window: Callable[[WindowPlan], None] | None = None,
    drone_models: Sequence[EnergyModel] | None = None,
) -> DayResult:
    """Plan every window of ``day``; ``on_window`` is called after each (for progress).
    ``drone_models`` are each drone's own (a mixed fleet), None: ``model`` for all."""
    model = model or EnergyModel.of(cfg.energy)
    # A policy that picks plans itself (the MAPPO baseline) carries its own selector.
    selector = selector or policy.selector or make_selector(cfg.plan)
    plan_cfg = plan_config(policy, cfg.plan)
    state = DayState(
        day, depots, drone_depot, cfg.plan.coverage, cfg.plan.ties, drone_models=drone_models
    )
    start_day(policy, cfg, cfg.sim.seed)
    plans: list[WindowPlan] = []
    t0 = time.perf_counter()
    for t in range(day.n_windows):
        view = state.view(t)
        actions = policy.act(view)
        plan = plan_window(view, actions, model, plan_cfg, selector, scope=policy.scope)
        state.apply(plan, model.speed_ms)
        plans.append(plan)
        if on_window is not None:
            on_window(plan)
    runtime = time.perf_counter() - t0
    return DayResult(method, state, plans, runtime, int(len(drone_depot)))
