"""What the route pool prices beyond a request's delay (docs/method.md §4.4): the energy
waiting would not save, in the day's last window the night a parcel left then would
wait, and ``serve_h``; J and G stay the window objective's."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from marops_cli.config import PlanConfig
from marops_cli.energy import EnergyModel
from marops_cli.plans.objective import lam_j, wait_credit_j
from marops_cli.plans.problem import pricing_delay_h

MODEL = EnergyModel()
E0 = float(MODEL.energy_per_m(0.0))


def _priced(view: SimpleNamespace, cfg: PlanConfig) -> np.ndarray:
    """The delay the pool prices each of ``view``'s requests at, λ from ``cfg``."""
    return pricing_delay_h(view, cfg, MODEL, lam_j(cfg.alpha, MODEL.usable_j))  # type: ignore[arg-type]


def _view(t: int, n_windows: int = 16, window_h: float = 0.5) -> SimpleNamespace:
    return SimpleNamespace(
        t=t,
        n_windows=n_windows,
        window_h=window_h,
        pending_delay_h=np.array([0.0, 1.5]),
        pending_xy=np.array([[0.0, 1000.0], [0.0, 1300.0]]),
        depots=SimpleNamespace(xy=np.array([[0.0, 0.0]])),
    )


def test_the_last_window_prices_the_night_the_others_do_not() -> None:
    cfg = PlanConfig(wait_credit=0.0)
    # 16 windows of half an hour: 8 service hours, a night of 24 - 8 = 16 h.
    np.testing.assert_allclose(_priced(_view(15), cfg), [16.0, 17.5])
    np.testing.assert_allclose(_priced(_view(14), cfg), [0.0, 1.5])
    # 4 windows of an hour: 20 h of night.
    np.testing.assert_allclose(_priced(_view(3, 4, 1.0), cfg), [20.0, 21.5])


@pytest.mark.parametrize(
    ("settings", "expected"),
    [
        ({"night_h": 0.0, "wait_credit": 0.0}, [0.0, 1.5]),
        ({"night_h": 2.0, "wait_credit": 0.0}, [2.0, 3.5]),
        ({"planner": "subsets"}, [0.0, 1.5]),
    ],
)
def test_night_h_sets_the_hours_and_the_papers_planner_prices_delay_alone(settings, expected):
    np.testing.assert_allclose(_priced(_view(15), PlanConfig(**settings)), expected)


def test_the_wait_credit_is_the_detour_from_the_nearest_request_or_depot() -> None:
    """A at (0, 1000), B at (0, 1300), depots at (0, 0) and (5000, 0), C at (4900, 0):
    A's nearest is B (300 m; the depot is 1,000 m), B's is A (300 m), C's the second
    depot (100 m). Each is credited 2 · that · the empty energy per metre."""
    xy = np.array([[0.0, 1000.0], [0.0, 1300.0], [4900.0, 0.0]])
    depots = np.array([[0.0, 0.0], [5000.0, 0.0]])
    got = wait_credit_j(xy, depots, E0)
    np.testing.assert_allclose(got, [600.0 * E0, 600.0 * E0, 200.0 * E0], rtol=1e-12)
    # A lone request: its nearest depot.
    np.testing.assert_allclose(wait_credit_j(xy[:1], depots, E0), [2000.0 * E0], rtol=1e-12)


def test_the_credit_is_priced_in_hours_of_lambda_in_every_window() -> None:
    cfg = PlanConfig(alpha=0.8, night_h=0.0)  # wait_credit 1 by default
    lam = lam_j(0.8, MODEL.usable_j)
    credit = 600.0 * E0 / lam  # A and B: 300 m from each other
    np.testing.assert_allclose(_priced(_view(3), cfg), [credit, 1.5 + credit], rtol=1e-12)


@pytest.mark.parametrize("t", [3, 15])
def test_serve_h_adds_its_hours_to_every_request_in_every_window(t: int) -> None:
    """With the credit off and a night of 2 h: 0.75 h more than without, in the last
    window (night priced too) and any other; the paper's planner ignores it."""
    base = PlanConfig(wait_credit=0.0, night_h=2.0)
    night = 2.0 if t == 15 else 0.0
    np.testing.assert_allclose(_priced(_view(t), base), [night, night + 1.5])
    more = PlanConfig(wait_credit=0.0, night_h=2.0, serve_h=0.75)
    np.testing.assert_allclose(_priced(_view(t), more), [night + 0.75, night + 2.25])
    paper = PlanConfig(planner="subsets", serve_h=0.75)
    np.testing.assert_allclose(_priced(_view(t), paper), [0.0, 1.5])
