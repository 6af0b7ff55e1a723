"""The one window step: replay and the training environment fly a window alike."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest

from marops_cli.config import EnergyConfig, PlannerConfig
from marops_cli.data.frame import Frame
from marops_cli.data.table import DayRequests
from marops_cli.errors import RunError
from marops_cli.plans.select import MilpSelector
from marops_cli.plans.view import FREE
from marops_cli.plans.window import WindowPlan
from marops_cli.policies.base import SLOT_PLANNER, PolicyBase, SlotActions, WindowView
from marops_cli.policies.direct import SlotSelector
from marops_cli.rl.config import TrainConfig
from marops_cli.rl.env import DeliveryEnv, trained_step
from marops_cli.segment.depots import Depots, nearest_candidates
from marops_cli.sim.fleet import DroneType, Fleet
from marops_cli.sim.replay import fly_day
from marops_cli.sim.state import DayState
from marops_cli.sim.step import WindowStep, fly_window, plan_step

FRAME = Frame(121.47, 31.23, 10.0)
N_WINDOWS = 4
N_ACTIONS = 3


def tiny_depots() -> Depots:
    """Six depots 2.5 km apart on a 3 × 2 grid, three actions each."""
    xy = np.array([[x, y] for y in (0.0, 2500.0) for x in (0.0, 2500.0, 5000.0)])
    return Depots(
        "kmeans", FRAME, xy, np.array([5, 9, 7, 3, 8, 6]), nearest_candidates(xy, N_ACTIONS)
    )


def tiny_day(n: int = 36, seed: int = 3) -> DayRequests:
    """``n`` requests over the grid, becoming visible through a 4-window day."""
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(-500.0, 5500.0, n), rng.uniform(-500.0, 3000.0, n)
    visible = rng.integers(0, N_WINDOWS, n).astype(np.int32)
    due = np.minimum(visible + rng.integers(0, 2, n), N_WINDOWS - 1).astype(np.int32)
    window_s = 1800.0
    return DayRequests(
        day=dt.date(2022, 8, 11),
        frame=FRAME,
        service_start_s=9 * 3600,
        window_s=window_s,
        n_windows=N_WINDOWS,
        order_id=np.array([f"o{i}" for i in range(n)], dtype=object),
        x_m=x,
        y_m=y,
        lng=np.zeros(n),
        lat=np.zeros(n),
        weight_kg=rng.uniform(0.2, 2.0, n),
        visible_w=visible,
        due_w=due,
        due_s=due * window_s + 900.0,
        accept_s=visible * window_s,
    )


class Scripted(PolicyBase):
    """Seeded random actions (the free landing among them), with plan slots when
    ``n_slots`` is given; keeps what it chose, window by window."""

    def __init__(self, scope: str = "range", n_slots: int | None = None) -> None:
        self.scope = scope  # type: ignore[assignment]
        self.n_slots = n_slots
        if n_slots is not None:
            self.planner, self.selector = SLOT_PLANNER, SlotSelector(n_slots)
        self.chosen: list[tuple[np.ndarray, np.ndarray | None]] = []

    def reset(self, seed: int) -> None:
        self._rng = np.random.default_rng(seed)
        self.chosen = []

    def act(self, view: WindowView) -> np.ndarray | SlotActions:
        actions = self._rng.integers(-1, N_ACTIONS, view.n_drones)  # -1: FREE
        slots = None if self.n_slots is None else self._rng.integers(0, self.n_slots, view.n_drones)
        self.chosen.append((actions, slots))
        return actions if slots is None else SlotActions(actions, slots)


def _routes(plan: WindowPlan) -> list[tuple]:
    return [
        (r.drone, r.start, r.end, r.action, r.stops, r.legs_m.tolist(), r.legs_j.tolist())
        for r in plan.routes
    ]


MIXED = Fleet(
    np.array([1, 4, 2]),
    np.array([0, 1, 0]),
    (
        DroneType("light", EnergyConfig(max_payload_kg=1.0, battery_j=150000.0, speed_ms=14.0)),
        DroneType("heavy", EnergyConfig(max_payload_kg=4.0, battery_j=400000.0, speed_ms=9.0)),
    ),
)
ONE_TYPE = Fleet.uniform(np.array([1, 4, 2]), EnergyConfig())


@pytest.mark.parametrize(
    ("planner", "scope", "fleet", "n_slots"),
    [
        pytest.param("pool", "range", ONE_TYPE, None, id="route-pool"),
        pytest.param("subsets", "range", ONE_TYPE, None, id="paper-subsets"),
        pytest.param("pool", "global", ONE_TYPE, None, id="global-pool"),
        pytest.param("subsets", "global", ONE_TYPE, None, id="global-subsets"),
        pytest.param("pool", "range", MIXED, None, id="mixed-fleet"),
        pytest.param("subsets", "global", MIXED, None, id="mixed-fleet-global"),
        # the MAPPO baseline: its slots rank the paper's subset plans, whatever the setting
        pytest.param("pool", "range", MIXED, 3, id="plan-slots"),
    ],
)
def test_an_environment_step_flies_the_replay_window(planner, scope, fleet, n_slots):
    """From the same state with the same actions, each environment step flies the routes
    the replay flew in that window, for the whole day."""
    cfg = PlannerConfig()
    cfg.plan.planner = planner
    cfg.plan.max_parcels = 3
    cfg.plan.pool_iterations = 20
    depots, day = tiny_depots(), tiny_day()
    policy = Scripted(scope, n_slots)
    res = fly_day(
        day, depots, fleet.depot, policy, cfg, method="scripted", drone_models=fleet.models()
    )
    assert sum(len(r.stops) for p in res.plans for r in p.routes) > 0  # something is flown

    how = WindowStep.of(policy, cfg)
    assert how.scope == scope and how.plan.planner == (SLOT_PLANNER if n_slots else planner)
    tcfg = TrainConfig(method="mappo", plan_slots=n_slots) if n_slots else TrainConfig()
    env = DeliveryEnv(depots, cfg, tcfg, n_drones=len(fleet), how=how)
    env.reset(day, fleet)
    s = env.n_slots
    for plan, (actions, slots) in zip(res.plans, policy.chosen, strict=True):
        choice = np.where(actions == FREE, env.n_dest, actions)
        env.step(choice * s + (0 if slots is None else slots))
        assert env.last_plan is not None
        assert _routes(env.last_plan) == _routes(plan)
    assert env.done and env.state is not None
    assert np.array_equal(env.state.delivered_w, res.state.delivered_w)
    assert np.array_equal(env.state.arrive_s, res.state.arrive_s, equal_nan=True)
    assert np.array_equal(env.state.drone_depot, res.state.drone_depot)


def test_the_mixed_fleet_flies_its_own_types():
    """Each drone's own type bounds and prices its routes and its speed its arrival times:
    the heavy drone carries more than the light one may, and the same actions flown by
    one type arrive at other times."""
    cfg = PlannerConfig()
    depots, day = tiny_depots(), tiny_day()
    models = MIXED.models()
    mixed = fly_day(day, depots, MIXED.depot, Scripted(), cfg, method="m", drone_models=models)
    one = fly_day(day, depots, MIXED.depot, Scripted(), cfg, method="m")
    routes = [r for p in mixed.plans for r in p.routes]
    for r in routes:
        assert r.payload_kg <= models[r.drone].max_payload_kg + 1e-9
        assert r.energy_j <= models[r.drone].usable_j + 1e-6
    assert max(r.payload_kg for r in routes if r.drone == 1) > models[0].max_payload_kg
    assert not np.array_equal(mixed.state.arrive_s, one.state.arrive_s, equal_nan=True)


def test_plan_step_plans_and_fly_window_applies():
    cfg = PlannerConfig()
    depots, day = tiny_depots(), tiny_day()
    how = WindowStep.of(PolicyBase(), cfg)
    state = DayState(day, depots, np.array([1, 4, 2]), cfg.plan.coverage)
    view = state.view(1)
    planned = plan_step(view, np.array([0, 1, FREE]), how)
    assert (state.delivered_w < 0).all()  # planning alone changes nothing
    flown = fly_window(state, 1, np.array([0, 1, FREE]), how)
    assert _routes(flown) == _routes(planned)
    stops = [i for r in flown.routes for i in r.stops]
    assert stops and (state.delivered_w[stops] == 1).all()
    assert state.drone_depot.tolist() == [r.end for r in flown.routes]


def test_slots_travel_with_the_actions_not_the_selector():
    """A policy's plan slots reach the planner with its actions; its selector keeps none."""
    cfg = PlannerConfig()
    depots, day = tiny_depots(), tiny_day()
    policy = Scripted(n_slots=3)
    how = WindowStep.of(policy, cfg)
    state = DayState(day, depots, np.array([1, 4, 2]), cfg.plan.coverage)
    view = state.view(2)
    acts = np.array([0, 0, 0])
    best = plan_step(view, SlotActions(acts, np.array([0, 0, 0])), how)
    empty = plan_step(view, SlotActions(acts, np.array([2, 2, 2])), how)  # last slot: empty
    assert any(r.stops for r in best.routes) and not any(r.stops for r in empty.routes)
    assert isinstance(how.selector, SlotSelector) and how.selector.slots is None
    with pytest.raises(RunError, match="slot selector"):
        plan_step(view, SlotActions(acts, np.zeros(3, np.int64)), WindowStep.make(cfg))


def test_steps_are_built_from_the_policy_and_the_settings():
    cfg = PlannerConfig()
    assert cfg.plan.planner != SLOT_PLANNER
    mappo = trained_step(cfg, TrainConfig(method="mappo", plan_slots=3))
    assert mappo.plan.planner == SLOT_PLANNER and mappo.selector.n_slots == 3  # type: ignore[attr-defined]
    own = trained_step(cfg, TrainConfig())
    assert own.plan is cfg.plan and isinstance(own.selector, MilpSelector)
    assert own.scope == "range" and WindowStep.of(Scripted("global"), cfg).scope == "global"
    assert own.at_alpha(cfg.plan.alpha) is own
    assert own.at_alpha(0.2).plan.alpha == 0.2 and own.plan.alpha == cfg.plan.alpha
    with pytest.raises(ValueError, match="plan slots"):
        DeliveryEnv(tiny_depots(), cfg, TrainConfig(), how=mappo)
