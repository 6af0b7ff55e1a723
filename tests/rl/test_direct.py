"""The MAPPO baseline's plan slots and its first-claim conflict rule."""

from __future__ import annotations

import numpy as np

from marops_cli.plans.plans import PlanSet, SelectionProblem
from marops_cli.policies.direct import SlotSelector, ranked_plans


def _plans(ids: list[int], energy: list[float]) -> PlanSet:
    """Two candidates: plans {}, {a}, {b}, {a, b} (bitmask order)."""
    members = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], dtype=bool)
    order = np.array([[-1, -1], [0, -1], [1, -1], [0, 1]], dtype=np.int8)
    e = np.array(energy)
    return PlanSet(np.array(ids), members, order, e, e * 0.01, np.zeros(4))


def _problem() -> SelectionProblem:
    # Drone 0 sees requests 10, 11; drone 1 sees 11, 12. Delays: 10 -> 0 h, 11 -> 2 h, 12 -> 1 h.
    ps = [_plans([10, 11], [5.0, 10.0, 12.0, 20.0]), _plans([11, 12], [5.0, 8.0, 9.0, 15.0])]
    return SelectionProblem.from_plan_sets(
        ps, {10: 0.0, 11: 2.0, 12: 1.0}, alpha=0.5, energy_ref_j=100.0
    )


def test_ranking_by_value_then_energy() -> None:
    p = _problem()
    # drone 0 values: {10}=1, {11}=3, {10,11}=4 -> plans 3, 2, 1
    assert ranked_plans(p, 0).tolist() == [3, 2, 1]
    # drone 1 values: {11}=3, {12}=2, {11,12}=5 -> plans 3, 1, 2
    assert ranked_plans(p, 1).tolist() == [3, 1, 2]


def test_first_claim_wins_and_last_slot_is_empty() -> None:
    p = _problem()
    sel = SlotSelector(4)
    r = sel.picking(np.array([0, 0])).select(p)
    # drone 0 takes {10, 11}; drone 1 wanted {11, 12}, 11 is taken -> flies {12} (plan 2)
    assert r.chosen.tolist() == [3, 2] and p.violation(r.chosen) is None
    # drone 0 flies empty; drone 1's second-best is {11}
    assert sel.picking(np.array([3, 1])).select(p).chosen.tolist() == [0, 1]
    # third-best: drone 0 {10}, drone 1 {12}
    assert sel.picking(np.array([2, 2])).select(p).chosen.tolist() == [1, 2]
    assert sel.slots is None and sel.select(p).chosen.tolist() == [3, 2]  # slot 0: the best
