"""Candidate plans of one drone and the table of all drones' plans."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from numpy.testing import assert_allclose

from marops_cli.config import EnergyConfig, PlanConfig
from marops_cli.energy import EnergyModel
from marops_cli.plans import (
    Candidates,
    NoFeasiblePlanError,
    PlanSet,
    SelectionProblem,
    build_plans,
)

# Two depots 1 km apart and five orders (ids 11..15), numbers checkable by hand.
START, END = (0.0, 0.0), (1000.0, 0.0)
XY = np.array([(0, 500), (500, 500), (1000, 500), (500, -500), (3500, 3500)], dtype=float)
W = np.array([0.5, 1.0, 0.8, 2.0, 0.3])
IDS = np.array([11, 12, 13, 14, 15])
CANDS = Candidates(XY, W, IDS)


@pytest.fixture(scope="module")
def model() -> EnergyModel:
    return EnergyModel()


@pytest.fixture(scope="module")
def plans(model) -> PlanSet:
    return build_plans(START, END, CANDS, model, PlanConfig())


def test_empty_plan_first_and_direct(plans, model):
    assert not plans.members[0].any()
    assert plans.route(0) == ()
    assert_allclose(plans.distance_m[0], 1000.0)
    assert_allclose(plans.energy_j[0], 1000.0 * model.energy_per_m(0.0), rtol=1e-12)


def test_plans_are_exactly_the_feasible_subsets(plans, model):
    expected = set()
    for r in range(6):
        for combo in itertools.combinations(range(5), r):
            if W[list(combo)].sum() > 2.5 + 1e-9:
                continue
            best = min(
                model.route_energy(np.vstack([START, XY[list(p)], END]), W[list(p)])[1].sum()
                for p in itertools.permutations(combo)
            )
            if best <= model.usable_j:
                expected.add(frozenset(combo))
    got = {frozenset(np.flatnonzero(row)) for row in plans.members}
    assert got == expected
    # 18 subsets fit the payload; the far order (id 15, ~5 km out) makes two of them
    # too long for the battery: {0, 2, 4} and {3, 4}
    assert len(got) == 16
    assert frozenset({0, 2, 4}) not in got and frozenset({3, 4}) not in got


def test_plan_rows_are_consistent(plans, model):
    assert plans.n_candidates == 5
    for k in range(plans.n_plans):
        stops = plans.stops(k)
        assert sorted(stops) == list(np.flatnonzero(plans.members[k]))
        assert plans.route(k) == tuple(int(IDS[j]) for j in stops)
        legs_m, legs_j = model.route_energy(
            np.vstack([START, XY[list(stops)], END]), W[list(stops)]
        )
        assert_allclose(plans.energy_j[k], legs_j.sum(), rtol=1e-12)
        assert_allclose(plans.distance_m[k], legs_m.sum(), rtol=1e-12)
        assert_allclose(plans.weight_kg[k], W[list(stops)].sum(), rtol=1e-12)
        assert plans.weight_kg[k] <= 2.5 + 1e-9
        assert plans.energy_j[k] <= model.usable_j


def test_max_parcels_limits_plan_size(model):
    plans = build_plans(START, END, CANDS, model, PlanConfig(max_parcels=2))
    assert plans.members.sum(axis=1).max() == 2


def test_greedy_ordering_option(model):
    depot = (0.0, 0.0)
    two = Candidates([(600, 0), (0, 700)], [0.1, 2.0])
    exact = build_plans(depot, depot, two, model, PlanConfig())
    greedy = build_plans(depot, depot, two, model, PlanConfig(ordering="greedy"))
    assert exact.route(exact.n_plans - 1) == (1, 0)
    assert greedy.route(greedy.n_plans - 1) == (0, 1)
    assert_allclose(exact.energy_j[-1], 43_466.7, rtol=1e-3)
    assert_allclose(greedy.energy_j[-1], 51_413.6, rtol=1e-3)


def test_battery_drops_plans(model):
    small = EnergyModel(EnergyConfig(battery_j=60_000.0))  # usable 45 kJ: ~2.8 km empty
    plans = build_plans(START, END, CANDS, small, PlanConfig())
    assert np.all(plans.energy_j <= small.usable_j)
    assert not plans.members[:, 4].any()  # the far order is out of range


def test_unreachable_destination_raises(model):
    with pytest.raises(NoFeasiblePlanError, match="exceeds the usable battery"):
        build_plans(START, (11_000.0, 0.0), Candidates(XY, W), model)


def test_bad_ids_raise(model):
    with pytest.raises(ValueError, match="request ids"):
        build_plans(START, END, Candidates(XY, W, [1, 2]), model)
    with pytest.raises(ValueError, match="distinct"):
        build_plans(START, END, Candidates(XY, W, [1, 1, 2, 3, 4]), model)


def test_selection_problem_table(model):
    a = build_plans(START, END, Candidates(XY[:3], W[:3], IDS[:3]), model, PlanConfig())
    b = build_plans(END, END, Candidates(XY[1:4], W[1:4], IDS[1:4]), model, PlanConfig())
    delay = {11: 0.0, 12: 0.5, 13: 1.0, 14: 2.0}
    prob = SelectionProblem.from_plan_sets([a, b], delay, alpha=0.2, energy_ref_j=100.0)
    assert prob.n_drones == 2 and prob.n_plans == a.n_plans + b.n_plans
    assert list(prob.request_ids) == [11, 12, 13, 14]
    assert_allclose(prob.value, [1.0, 1.5, 2.0, 3.0])
    assert prob.lam == pytest.approx(400.0)  # (1 - 0.2) / 0.2 * 100
    # column offsets[u] + k is plan k of drone u
    k = a.n_plans - 1
    served = prob.cover[:, k].toarray().ravel()
    assert_allclose(served, np.isin(prob.request_ids, [IDS[j] for j in a.stops(k)]))
    assert_allclose(prob.cost[k], a.energy_j[k] - 400.0 * prob.value[served > 0].sum())
    chosen = np.array([k, 0])
    assert prob.violation(chosen) is None
    assert_allclose(
        prob.objective(chosen),
        a.energy_j[k] + b.energy_j[0] + 400.0 * prob.value[served == 0].sum(),
    )
    # both drones serving order 12 is caught
    both = np.array([1 << 1, 1 << 0])  # plan {12} of a (bit 1), plan {12} of b (bit 0)
    ka = int(np.flatnonzero((a.members * (1 << np.arange(3))).sum(axis=1) == both[0])[0])
    kb = int(np.flatnonzero((b.members * (1 << np.arange(3))).sum(axis=1) == both[1])[0])
    assert "twice" in prob.violation(np.array([ka, kb]))
    assert "one plan per drone" in prob.violation(np.array([0]))
    assert "out of range" in prob.violation(np.array([0, b.n_plans]))


def test_selection_problem_checks_its_input(plans):
    delay = {int(i): 0.0 for i in IDS}
    with pytest.raises(ValueError, match="missing"):
        SelectionProblem.from_plan_sets([plans], {11: 0.0}, alpha=0.5, energy_ref_j=1.0)
    with pytest.raises(ValueError, match="alpha"):
        SelectionProblem.from_plan_sets([plans], delay, alpha=0.0, energy_ref_j=1.0)
    no_empty = PlanSet(
        plans.request_ids, plans.members[1:], plans.order[1:], plans.energy_j[1:],
        plans.distance_m[1:], plans.weight_kg[1:],
    )  # fmt: skip
    with pytest.raises(ValueError, match="empty plan"):
        SelectionProblem.from_plan_sets([no_empty], delay, alpha=0.5, energy_ref_j=1.0)
