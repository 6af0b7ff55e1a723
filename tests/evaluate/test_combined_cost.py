"""Combined cost (docs/method.md §8) against the paper's Table III; flattening day metrics."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

from marops_cli.evaluate import combined_cost
from marops_cli.evaluate.paper import TABLE3
from marops_cli.evaluate.tables import flatten, mean_std

# Paper Table III (basic scenario): OPS-global, OPS-random, MAPPO, Squares, MAR-OPS.
ORDER = ["ops-global", "ops-random", "mappo", "squares", "marops"]
ENERGY_KJ = [TABLE3["mean_energy_kj"][m][0] for m in ORDER]
DELAY_H = [TABLE3["avg_delay_h"][m][0] for m in ORDER]
PAPER_COST = [TABLE3["combined_cost"][m][0] for m in ORDER]


def test_table_values_are_the_papers() -> None:
    assert ENERGY_KJ == [1551, 662.0, 664.3, 1768, 669.1]
    assert DELAY_H == [0.67, 1.17, 1.46, 1.15, 0.88]
    assert PAPER_COST == [0.66, 0.57, 0.67, 0.87, 0.48]


def test_spec_worked_example() -> None:
    # docs/method.md §8: MAR-OPS 669.1/1768 and 0.88/1.46 -> 0.49.
    assert round(float(combined_cost(ENERGY_KJ, DELAY_H)[4]), 2) == 0.49


def test_reproduces_table_iii_from_its_means() -> None:
    cost = combined_cost(ENERGY_KJ, DELAY_H)
    # Per method: 0.668 0.588 0.688 0.894 0.491. The paper prints each 0.008-0.024
    # lower; a least-squares fit of its table gives normalisers of 1786 kJ and 1.51 h,
    # just above the largest means (1768, 1.46), as normalising each run by that run's
    # maxima would. So the formula holds to 0.025 on the means, and the ranking exactly.
    assert_allclose(cost, PAPER_COST, atol=0.025)
    assert list(np.argsort(cost)) == list(np.argsort(PAPER_COST))
    assert np.all(cost >= np.array(PAPER_COST))


def test_worst_method_scores_one_and_zero_maxima_are_safe() -> None:
    assert_allclose(combined_cost([2.0, 1.0], [4.0, 2.0]), [1.0, 0.5])
    assert_allclose(combined_cost([2.0, 1.0], [0.0, 0.0]), [0.5, 0.25])


def test_flatten_nested_metrics() -> None:
    rec = {"a": 1, "solver": {"calls": 3, "solve_s": 0.5}, "depot_load_kg": {"0": 1.5}}
    assert flatten(rec) == {
        "a": 1,
        "solver_calls": 3,
        "solver_solve_s": 0.5,
        "depot_load_kg_0": 1.5,
    }


def test_mean_std_is_sample_std() -> None:
    assert mean_std(np.array([1.0, 3.0])) == (2.0, float(np.sqrt(2.0)))
    mean, std = mean_std(np.array([4.0]))
    assert mean == 4.0 and np.isnan(std)  # one day: no spread (shown as n/a)
    from marops_cli.evaluate.report import mean_pm_std

    assert mean_pm_std({"x_mean": 4.0, "x_std": std}, "x") == "4.00 ± n/a"
    assert mean_pm_std({"x_mean": 4.0, "x_std": 0.5}, "x") == "4.00 ± 0.50"
