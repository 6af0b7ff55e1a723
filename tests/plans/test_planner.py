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
