"""Observation version 4: the anticipation features, checked by hand on a tiny map."""

from __future__ import annotations

import numpy as np
import pytest

from marops_cli.config import PlanConfig
from marops_cli.data.frame import Frame
from marops_cli.plans.ranges import range_table
from marops_cli.plans.view import FREE
from marops_cli.policies import WindowView
from marops_cli.policies.observation import (
    GLOBAL_V4,
    PER_ACTION_V3,
    PER_ACTION_V4,
    VALUE,
    SequentialObserver,
    choice_mask,
    n_choices,
    obs_dim,
    observe_and_choose,
    to_actions,
)
from marops_cli.segment.depots import Depots, nearest_candidates

FRAME = Frame(121.47, 31.23, 10.0)
XY = np.array([[0.0, 0.0], [2000.0, 0.0], [4000.0, 0.0]])


def _view(arrivals: np.ndarray | None, visible_w: list[int] | None) -> WindowView:
    """Depots on a line at 0 / 2 / 4 km, 2 actions each; window t = 4 of 8; two drones
    at depot 0; pending requests near depots 2, 2 and 0."""
    dep = Depots("kmeans", FRAME, XY, np.zeros(3, np.int64), nearest_candidates(XY, 2), arrivals)
    pxy = np.array([[4000.0, 50.0], [3900.0, 0.0], [100.0, 0.0]])
    return WindowView.paper(
        t=4,
        n_windows=8,
        window_h=0.5,
        depots=dep,
        ranges=range_table(dep, 0.34),
        drone_depot=np.array([0, 0]),
        pending_idx=np.arange(3),
        pending_xy=pxy,
        pending_area=dep.assign(pxy[:, 0], pxy[:, 1]),
        pending_delay_h=np.array([0.5, 0.0, 0.0]),
        pending_due_w=np.array([3, 5, 6]),
        pending_due_s=np.array([5400.0, 9000.0, 10800.0]),
        pending_weight=np.full(3, 0.5),
        pending_visible_w=None if visible_w is None else np.array(visible_w),
    )


def test_version_4_features_by_hand() -> None:
    prof = np.zeros((3, 8))
    prof[1, 5] = 3.0  # depot 1 expects 3 arrivals next window (t + 1 = 5)
    prof[2, 5], prof[2, 6] = 1.0, 2.0
    prof[2, 4] = 1.0  # and one in this window at depot 2
    view = _view(prof, [4, 4, 1])  # two of the requests at depot 2 are new this window
    cand = view.depots.candidates  # [[0, 1], [1, 0], [2, 1]]
    assert cand.tolist() == [[0, 1], [1, 0], [2, 1]]
    seq = SequentialObserver(view, plan=PlanConfig(alpha=0.3), version=4)
    row = seq.row(0)
    assert row.shape == (obs_dim(2, 4),) == (3 * PER_ACTION_V4 + GLOBAL_V4,)  # 2 + free
    stay, move = row[:PER_ACTION_V4], row[PER_ACTION_V4 : 2 * PER_ACTION_V4]
    tol = 1e-6
    # 13: expected arrivals next window in the destination's own area.
    assert stay[13] == pytest.approx(0.0, abs=tol)
    assert move[13] == pytest.approx(np.log1p(3.0), abs=tol)
    # 14: expected over the next two windows in nb(d) = candidates[d]: depot 1's is {1, 0}.
    assert move[14] == pytest.approx(np.log1p(3.0), abs=tol)
    assert stay[14] == pytest.approx(np.log1p(3.0), abs=tol)  # nb(0) = {0, 1}
    # 15, 16: no new request in nb(0) = nb(1) = {0, 1} this window; usual there: 0.
    assert stay[15] == pytest.approx(0.0, abs=tol) and stay[16] == pytest.approx(0.0, abs=tol)
    # 17: drones in nb(d) after the window: u itself is not counted, drone 1 still at 0.
    assert stay[17] == pytest.approx(np.log1p(1.0), abs=tol)
    g = row[3 * PER_ACTION_V4 :]
    assert g[7] == pytest.approx(0.3, abs=tol)  # α
    assert g[8] == pytest.approx(6.0 / 7.0, abs=tol)  # arrivals still to come (t > 4): 6 of 7
    # The first 13 features of each action are version 3's.
    v3 = SequentialObserver(view, plan=PlanConfig(alpha=0.3), version=3).row(0)
    np.testing.assert_allclose(stay[:13], v3[:PER_ACTION_V3], atol=tol)
    # Drone 0 flies to depot 1: drone 1 then sees it there.
    seq.commit(0, 1)
    assert seq.row(1)[PER_ACTION_V4 + 17] == pytest.approx(np.log1p(1.0), abs=tol)


def test_depot_2_sees_todays_rate_against_usual() -> None:
    prof = np.zeros((3, 8))
    prof[2, 4] = 1.0
    view = _view(prof, [4, 4, 1])
    view.drone_depot = np.array([2, 2])
    row = SequentialObserver(view, version=4).row(0)
    stay = row[:PER_ACTION_V4]  # destination 2, nb(2) = {2, 1}: 2 new requests, 1 usual
    assert stay[15] == pytest.approx(np.log1p(2.0), abs=1e-6)
    assert stay[16] == pytest.approx(np.log(3.0 / 2.0), abs=1e-6)


def test_unknown_profile_and_arrivals_give_zeros_not_errors() -> None:
    view = _view(None, None)
    obs, actions = observe_and_choose(view, lambda u, o: np.zeros(len(u), np.int64), 4)
    assert obs.shape == (2, obs_dim(2, 4)) and np.isfinite(obs).all()
    for k in range(3):
        assert np.all(obs[:, k * PER_ACTION_V4 + 13 : k * PER_ACTION_V4 + 17] == 0)
    assert actions.tolist() == [0, 0]


def test_the_free_landing_block_prices_the_open_end() -> None:
    """The last block: staying's features, with the best plan priced with a free end (the
    depot nearest the last customer), so it is worth at least staying's."""
    view = _view(None, [1, 1, 1])
    view.drone_depot = np.array([1, 1])
    seq = SequentialObserver(view, version=4)
    row = seq.row(0)
    stay, free = row[:PER_ACTION_V4], row[2 * PER_ACTION_V4 : 3 * PER_ACTION_V4]
    np.testing.assert_allclose(free[:10], stay[:10], atol=1e-6)  # same range features
    assert free[VALUE] >= stay[VALUE] - 1e-6
    assert free[VALUE + 1] <= stay[VALUE + 1] + 1e-6  # no flight back to the depot
    assert free[12] == 0.0
    seq.commit(0, 2)  # choose the free landing: its plan's requests are claimed
    assert seq.claimed.any() and seq.dest[0] == 1


def test_free_choice_maps_to_the_free_action() -> None:
    view = _view(None, None)
    mask = choice_mask(view, 4)
    assert mask.shape == (2, 3) and mask.all()
    assert choice_mask(view, 3).shape == (2, 2)
    assert to_actions(np.array([0, 2, 1]), 2).tolist() == [0, FREE, 1]
    assert n_choices(2, 4) == 3 and n_choices(2, 3) == 2


def test_version_5_is_version_4_plus_the_drones_own_type() -> None:
    """Version 5 (docs/method.md §6): with one type it is version 4 and then 1, 1, 1; a
    light drone (1 kg, a third of the battery, 14 m/s) sees its own ratios, and its
    best plans are priced with its own energy model (cheaper per metre, so a cheaper
    plan relative to its own battery can still be worth less)."""
    from marops_cli.config import EnergyConfig
    from marops_cli.energy import EnergyModel
    from marops_cli.policies.observation import GLOBAL_V5, ObsVersion

    prof = np.zeros((3, 8))
    view = _view(prof, [4, 4, 1])
    n_a = view.depots.candidates.shape[1]
    v4 = SequentialObserver(view, version=ObsVersion.ANTICIPATION).row(0)
    v5 = SequentialObserver(view, version=ObsVersion.CAPABILITIES).row(0)
    assert obs_dim(n_a, 5) == obs_dim(n_a, 4) + 3 == v5.size and GLOBAL_V5 == GLOBAL_V4 + 3
    np.testing.assert_array_equal(v5[:-3], v4)
    np.testing.assert_array_equal(v5[-3:], [1.0, 1.0, 1.0])
    ref = EnergyModel()
    light = EnergyModel(EnergyConfig(max_payload_kg=1.0, battery_j=75_000.0, speed_ms=14.0))
    view.drone_models = (light, ref)
    seq = SequentialObserver(view, model=ref, version=ObsVersion.CAPABILITIES)
    row0 = seq.row(0)
    assert row0[-3:] == pytest.approx([1.0 / 2.5, 75_000.0 / 225_000.0, 1.4], rel=1e-6)
    per = PER_ACTION_V4
    for k in range(n_choices(n_a, 4)):  # every best plan fits the light drone's own battery
        assert row0[k * per + VALUE + 1] <= 1.0 + 1e-9
    assert not np.array_equal(row0[: n_choices(n_a, 4) * per], v4[: n_choices(n_a, 4) * per])
    seq.commit(0, 0)
    row1 = seq.row(1)
    assert row1[-3:] == pytest.approx([1.0, 1.0, 1.0])
