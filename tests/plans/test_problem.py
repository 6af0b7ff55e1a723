"""The window problem (docs/decisions.md, "The window problem"): built once per window,
the paper's model filled in as values, λ from one place."""

from __future__ import annotations

import ast
import pathlib
import warnings
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from marops_cli.config import EnergyConfig, PlanConfig
from marops_cli.energy import EnergyModel
from marops_cli.plans import problem as problem_mod
from marops_cli.plans.objective import lam_j
from marops_cli.plans.problem import EVERY_DEPOT, WindowProblem
from marops_cli.plans.view import FREE

from .test_window import hand_view

PLANS = pathlib.Path(problem_mod.__file__).parent


@pytest.fixture(scope="module")
def model() -> EnergyModel:
    return EnergyModel()


def test_the_papers_model_is_filled_in_as_values(model):
    """A view with one drone type, parcels at every depot and every drone ready gives a
    problem whose tasks each carry that model, every parcel at every depot and every
    drone ready; λ is ((1 − α)/α) · the usable battery."""
    view = hand_view()
    cfg = PlanConfig(alpha=0.2)
    problem = WindowProblem.of(view, np.array([0, 1]), model, cfg)
    assert [t.model for t in problem.tasks] == list(view.drone_models)
    assert (problem.stock == EVERY_DEPOT).all() and problem.ready.all()
    assert problem.lam == lam_j(0.2, model.usable_j) == pytest.approx(4 * model.usable_j)
    assert_array_equal(problem.value, 1.0 + view.pending_delay_h)
    assert_array_equal(problem.prize, problem.lam * problem.value)
    # Every drone may serve every request (reach), landing at its action's destination.
    assert [(t.start, t.end) for t in problem.tasks] == [(0, 0), (1, 0)]
    assert all(t.allowed.tolist() == [0, 1, 2, 3, 4] for t in problem.tasks)


def test_a_mixed_fleet_home_stock_and_a_grounded_drone(model):
    """Each drone's own model, the parcels its depot stocks, and a drone that cannot fly
    stays with no request; the relaxed problem lands every flying drone freely."""
    light = EnergyModel(EnergyConfig(max_payload_kg=1.0))
    view = replace(
        hand_view(),
        drone_models=(light, model),
        pending_stock=np.array([0, 1, 0, 0, 1]),
        drone_ready=np.array([True, False]),
    )
    problem = WindowProblem.of(view, np.array([1, FREE]), model, PlanConfig())
    assert problem.models == [light, model]
    assert problem.actions.tolist() == [1, 0]  # the grounded drone stays
    fly, grounded = problem.tasks
    assert fly.allowed.tolist() == [0, 2, 3] and grounded.allowed.size == 0
    relaxed = problem.relaxed()
    assert [(t.start, t.end) for t in relaxed.tasks] == [(0, -1), (1, 1)]
    assert relaxed.tasks[0].allowed.tolist() == [0, 2, 3] and relaxed.tasks[1].allowed.size == 0


def test_only_the_pool_prices_the_night(model):
    """In the day's last window the pool prices the night a parcel left waits; the
    paper's planner the delay alone (docs/method.md §4.4)."""
    view = replace(hand_view(), t=15)
    pool = WindowProblem.of(
        view, np.array([0, 1]), model, PlanConfig(night_h=8.0, wait_credit=0, pool_urgency=0)
    )
    paper = WindowProblem.of(view, np.array([0, 1]), model, PlanConfig(planner="subsets"))
    assert_array_equal(pool.priced_h, view.pending_delay_h + 8.0)
    assert_array_equal(paper.priced_h, view.pending_delay_h)
    assert_array_equal(pool.search, pool.lam * pool.priced)


def _imports(name: str) -> set[str]:
    """The modules of the plans package that ``name`` imports, anywhere in the file."""
    tree = ast.parse((PLANS / f"{name}.py").read_text())
    return {
        node.module
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module
    }


def test_the_bound_and_the_window_import_one_way():
    """The window imports the bound; the bound imports neither the window nor the
    planner (not even inside a function)."""
    assert "bound" in _imports("window")
    assert not {"window", "planner"} & _imports("bound")


def test_lambda_is_derived_in_one_place_in_the_planning_core():
    """Only the window problem's builder (and the selection's α-based constructor kept
    for callers outside the core) asks for λ; everything else reads ``problem.lam``."""
    callers = {
        p.stem for p in PLANS.glob("*.py") if "lam_j(" in p.read_text() and p.stem != "objective"
    }
    assert callers == {"problem", "plans"}


def test_alpha_one_prices_every_request_at_a_number(model):
    """At α = 1 (λ = 0) the pool's wait credit is left out: every priced delay, prize and
    search prize is a finite number, with no warning of a division by zero."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        problem = WindowProblem.of(hand_view(), np.array([0, 1]), model, PlanConfig(alpha=1.0))
    assert problem.lam == 0.0
    assert np.isfinite(problem.priced_h).all() and np.isfinite(problem.search).all()
    assert_array_equal(problem.search, np.zeros(problem.n_requests))
