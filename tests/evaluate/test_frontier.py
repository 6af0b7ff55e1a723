"""The frontier over α (docs/outputs.md, "Frontier"): pooled operating points and
dominance, hand-checked."""

from __future__ import annotations

import pyarrow as pa
import pytest

from marops_cli.app.evaluate import sweep_fields
from marops_cli.errors import InputError
from marops_cli.evaluate.frontier import FRONTIER_ALPHAS, dominated_by, frontier_table


def test_dominance_needs_all_three_and_one_strictly() -> None:
    points = [
        (100.0, 0.50, 10.0),  # 0
        (100.0, 0.50, 10.0),  # 1: the same point: neither dominates the other
        (101.0, 0.50, 10.0),  # 2: delivers more, the rest equal: dominates 0 and 1
        (120.0, 0.40, 11.0),  # 3: better on two, worse on energy: dominates none of them
        (90.0, 0.60, 12.0),  # 4: dominated by 0, 1, 2 and 3
    ]
    by = dominated_by(points)
    assert by[0] == 2 and by[1] == 2
    assert by[2] is None and by[3] is None
    assert by[4] == 3  # of those that dominate it, the one that delivers most


def _rows(method: str, alpha: float, days: list[tuple[int, int, float, float]]) -> list[dict]:
    return [
        {
            "drones": 8,
            "coverage": 0.25,
            "depots_n": 16,
            "n_actions": 4,
            "alpha": alpha,
            "method": method,
            "delivered": d,
            "requests": n,
            "avg_delay_h": t,
            "energy_kj": e,
            "objective_j_mj": 1.0,
        }
        for d, n, t, e in days
    ]


def test_a_point_pools_its_days_and_weighs_delay_by_requests() -> None:
    rows = _rows("a", 0.5, [(90, 100, 0.2, 1000.0), (270, 300, 0.6, 3000.0)])
    rows += _rows("a", 0.9, [(80, 100, 0.4, 500.0), (250, 300, 0.8, 2000.0)])
    rows += _rows("b", 0.5, [(90, 100, 0.3, 1100.0), (270, 300, 0.7, 3100.0)])
    front = frontier_table(pa.Table.from_pylist(rows))
    assert front is not None
    got = {(r["method"], r["alpha"]): r for r in front.to_pylist()}
    a5 = got[("a", 0.5)]
    assert a5["delivered"] == 180.0  # (90 + 270) / 2 days
    assert a5["delivered_share"] == pytest.approx(360 / 400)
    assert a5["avg_delay_h"] == pytest.approx((0.2 * 100 + 0.6 * 300) / 400)  # 0.5 h
    assert a5["energy_kj"] == 2000.0
    assert a5["energy_per_parcel_kj"] == pytest.approx(4000.0 / 360)
    assert not a5["dominated"] and not got[("a", 0.9)]["dominated"]
    assert got[("b", 0.5)]["dominated"] and got[("b", 0.5)]["dominated_by"] == "a α=0.5"


def test_no_frontier_without_two_values_of_alpha() -> None:
    rows = _rows("a", 0.5, [(90, 100, 0.2, 1000.0)]) + _rows("b", 0.5, [(80, 100, 0.3, 900.0)])
    assert frontier_table(pa.Table.from_pylist(rows)) is None


def test_the_frontier_switch_sweeps_the_grid_and_refuses_alpha_beside_it() -> None:
    assert tuple(sweep_fields(None, None, None, None, True)["alpha"]) == FRONTIER_ALPHAS
    with pytest.raises(InputError, match="give at most one of --alpha or --frontier"):
        sweep_fields("0.5", None, None, None, True)
