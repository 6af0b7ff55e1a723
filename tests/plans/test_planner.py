"""The planner is chosen once from the config; a given planner is the one plan_routes uses."""

from __future__ import annotations

import numpy as np
import pytest

from marops_cli.config import PlanConfig
from marops_cli.energy import EnergyModel
from marops_cli.plans import MilpSelector
from marops_cli.plans.planner import (
    PyvrpPoolPlanner,
    RoutePoolPlanner,
    SubsetsPlanner,
    make_planner,
)
from marops_cli.plans.problem import WindowProblem
from marops_cli.plans.view import FREE
from marops_cli.plans.window import plan_routes

from .test_window import hand_view


@pytest.mark.parametrize("scope", ["range", "global"])
def test_make_planner_follows_the_config(scope):
    subsets = make_planner(PlanConfig(planner="subsets", pyvrp_iterations=5), scope)
    assert type(subsets) is SubsetsPlanner and subsets.scope == scope
    pool = make_planner(PlanConfig(planner="pool"), scope)
    assert type(pool) is RoutePoolPlanner and pool.scope == scope
    assert pool.pyvrp_iterations() == 0
    pyvrp = make_planner(PlanConfig(planner="pool", pyvrp_iterations=7), scope)
    assert type(pyvrp) is PyvrpPoolPlanner and pyvrp.pyvrp_iterations() == 7


def test_make_planner_rejects_an_unknown_scope():
    with pytest.raises(ValueError, match="scope"):
        make_planner(PlanConfig(), "everywhere")  # type: ignore[arg-type]


def test_subsets_fly_free_as_stay_and_only_the_pool_reorders():
    model = EnergyModel()
    view = hand_view()
    acts = np.array([0, FREE])
    paper_cfg = PlanConfig(planner="subsets")
    problem = WindowProblem.of(view, acts, model, paper_cfg)
    paper = SubsetsPlanner(paper_cfg).plans(problem, view)
    assert paper.actions.tolist() == [0, 0] and not paper.reorder
    assert all((e >= 0).all() for e in paper.ends)  # every plan lands where its action says
    pool = RoutePoolPlanner(PlanConfig()).plans(
        WindowProblem.of(view, acts, model, PlanConfig()), view
    )
    assert pool.actions.tolist() == [0, FREE] and pool.reorder
    assert (pool.ends[1] == -1).all()  # the free landing: nearest the last customer


@pytest.mark.parametrize("scope", ["range", "global"])
def test_a_given_planner_overrides_the_config(scope):
    """A planner given wins over ``cfg.planner``: the subsets planner given with a pool
    config plans exactly what the subsets config plans by itself."""
    model = EnergyModel()
    acts = np.array([0, FREE])  # the pool records FREE, the paper's planner flies it as stay
    paper = PlanConfig(planner="subsets")
    given = plan_routes(
        hand_view(),
        acts,
        model,
        PlanConfig(),
        MilpSelector(),
        SubsetsPlanner(paper, scope),
    )
    own = plan_routes(hand_view(), acts, model, paper, MilpSelector(), scope)
    assert [(r.stops, r.end, r.action) for r in given.routes] == [
        (r.stops, r.end, r.action) for r in own.routes
    ]


@pytest.mark.parametrize("pack", [0.0, 0.5, 1.0])
def test_a_pyvrp_column_is_priced_as_the_pool_prices_its_own(pack):
    """Depot 0 at (0, 0), depot 1 at (3000, 0); a drone from depot 0 landing at the depot
    nearest its last stop serves A (0, 1000) 0.5 kg then B (2000, 1000) 1.0 kg: legs of
    1,000 m with 1.5 kg, 2,000 m with 1.0 kg, then the empty leg to depot 1 (√2 km).
    Its exact energy is theirs; ``pack_price`` p prices each loaded leg at
    (1 − p) e(load) + p e(2.5), the empty leg as it is."""
    from marops_cli.plans.planner import _route_energy_j
    from marops_cli.plans.problem import DroneTask

    model = EnergyModel()
    e = lambda kg: float(model.energy_per_m(kg))  # noqa: E731
    task = DroneTask(0, -1, np.arange(2, dtype=np.int64), model)
    problem = WindowProblem.of_requests(
        np.array([[0.0, 0.0], [3000.0, 0.0]]),
        np.array([[0.0, 1000.0], [2000.0, 1000.0]]),
        np.array([0.5, 1.0]),
        np.zeros(2),
        1.0,
        [task],
    )
    last = 1000.0 * np.sqrt(2.0) * e(0.0)
    exact = 1000.0 * e(1.5) + 2000.0 * e(1.0) + last
    priced = (
        1000.0 * ((1 - pack) * e(1.5) + pack * e(2.5))
        + 2000.0 * ((1 - pack) * e(1.0) + pack * e(2.5))
        + last
    )
    got = _route_energy_j(problem, task, np.array([0, 1]), pack)
    np.testing.assert_allclose(got, (exact, priced), rtol=1e-9)
