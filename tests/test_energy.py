"""Energy model (docs/method.md §3) against the reference values of docs/method.md §3."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from marops_cli.config import EnergyConfig
from marops_cli.energy import EnergyModel, power_curve_w, reference_power_w

REF_RTOL = 1e-3  # docs/method.md §3: "tests reproduce these to 0.1 %"

# payload kg, power W, energy kJ/km (docs/method.md §3)
REFERENCE = [
    (0.0, 159.91, 15.991),
    (0.5, 180.91, 18.091),
    (1.0, 204.99, 20.499),
    (1.5, 231.99, 23.199),
    (2.0, 261.79, 26.179),
    (2.5, 294.26, 29.426),
]


@pytest.fixture(scope="module")
def model() -> EnergyModel:
    return EnergyModel()


@pytest.mark.parametrize(("payload", "power", "kj_per_km"), REFERENCE)
def test_power_and_energy_per_km_match_reference(model, payload, power, kj_per_km):
    assert_allclose(reference_power_w(payload), power, rtol=REF_RTOL)
    assert_allclose(power_curve_w(payload), power, rtol=REF_RTOL)
    assert_allclose(model.power_w(payload), power, rtol=REF_RTOL)
    # J/m is kJ/km
    assert_allclose(model.energy_per_m(payload), kj_per_km, rtol=REF_RTOL)
    assert_allclose(model.leg_energy_j(1000.0, payload), 1000 * kj_per_km, rtol=REF_RTOL)


def test_newton_solution_equals_bracketed_root():
    payloads = np.linspace(0.0, 2.5, 11)
    exact = [reference_power_w(p) for p in payloads]
    assert_allclose(power_curve_w(payloads), exact, rtol=1e-12)


def test_induced_velocity_equation_holds():
    # eq. (7) with the values the model uses, checked independently of the solver
    cfg = EnergyConfig()
    p = 1.2
    w = (cfg.body_kg + cfg.battery_kg + p) * cfg.g
    d = 0.5 * cfg.air_density * cfg.speed_ms**2 * cfg.cda_m2
    theta = math.atan(d / w)
    thrust = w * (1 + math.tan(theta))
    assert_allclose(thrust, w + d, rtol=1e-12)  # docs/method.md §3: T = W (1 + tan θ) = W + D
    v_hat = reference_power_w(p) * cfg.efficiency / thrust - cfg.speed_ms * math.sin(theta)
    v = cfg.speed_ms
    rhs = (
        2
        * thrust
        / (
            math.pi
            * cfg.rotor_diameter_m**2
            * cfg.rotors
            * cfg.air_density
            * math.sqrt((v * math.cos(theta)) ** 2 + (v * math.sin(theta) + v_hat) ** 2)
        )
    )
    assert_allclose(v_hat, rhs, rtol=1e-10)


def test_interpolated_table_within_a_hundredth_of_a_percent_of_exact(model):
    rng = np.random.default_rng(0)
    payloads = np.concatenate([rng.uniform(0, 2.5, 2000), model.grid_kg[:-1] + 0.0005])
    assert_allclose(model.power_w(payloads), power_curve_w(payloads), rtol=1e-4)
    spot = [0.0123, 0.777, 1.9999, 2.4321]
    assert_allclose(model.power_w(spot), [reference_power_w(p) for p in spot], rtol=1e-4)


def test_route_of_energy_md(model):
    pts = [(0, 0), (1000, 0), (1000, 1000), (0, 1000)]
    legs_m, legs_j = model.route_energy(pts, [1.0, 0.5])
    assert_allclose(legs_m, [1000, 1000, 1000], rtol=1e-12)
    # legs flown with 1.5, 0.5 and 0 kg on board (eq. (6))
    assert_allclose(legs_j, model.leg_energy_j(1000.0, [1.5, 0.5, 0.0]), rtol=1e-12)
    assert_allclose(legs_j.sum(), 57_281.7, rtol=REF_RTOL)


def test_order_example_of_energy_md(model):
    a, b = (600, 0), (0, 700)
    _, a_first = model.route_energy([(0, 0), a, b, (0, 0)], [0.1, 2.0])
    _, b_first = model.route_energy([(0, 0), b, a, (0, 0)], [2.0, 0.1])
    assert_allclose(a_first.sum(), 51_413.6, rtol=REF_RTOL)
    assert_allclose(b_first.sum(), 43_466.7, rtol=REF_RTOL)
    assert_allclose(1 - b_first.sum() / a_first.sum(), 0.155, atol=5e-4)


def test_usable_battery_and_range(model):
    assert model.usable_j == pytest.approx(168_750.0)
    assert model.speed_ms == 10.0
    # docs/method.md §3: "about 10.6 km empty and 5.7 km fully loaded"
    assert_allclose(model.max_range_m(0.0), 10_600, rtol=0.01)
    assert_allclose(model.max_range_m(2.5), 5_700, rtol=0.01)


def test_empty_route_and_vectorised_legs(model):
    legs_m, legs_j = model.route_energy([(0, 0), (300, 400)], [])
    assert_allclose(legs_m, [500.0])
    assert_allclose(legs_j, [500.0 * model.energy_per_m(0.0)])
    grid = model.leg_energy_j(np.full((2, 3), 100.0), np.array([[0, 1, 2], [0.5, 1.5, 2.5]]))
    assert grid.shape == (2, 3)


def test_payload_outside_table_raises(model):
    with pytest.raises(ValueError, match="expected payload"):
        model.power_w(2.6)
    with pytest.raises(ValueError, match="expected payload"):
        model.leg_energy_j(100.0, -0.1)
    with pytest.raises(ValueError, match="expected 4 points"):
        model.route_energy([(0, 0), (1, 1), (2, 2)], [0.5, 0.5])


def test_a_payload_limit_below_the_table_step_has_one_step():
    """A limit far below the table's step (inside its documented range) made a table of no
    step and a division by zero; it is one step, from empty to the limit."""
    tiny = EnergyModel(EnergyConfig(max_payload_kg=1e-300))
    assert tiny.grid_kg.tolist() == [0.0, 1e-300]
    assert np.isfinite(tiny.power_w(0.0))


def test_parcel_drag_adds_power():
    base = EnergyModel(EnergyConfig())
    draggy = EnergyModel(EnergyConfig(parcel_cda_m2=0.02))
    assert_allclose(draggy.power_w(0.0), base.power_w(0.0), rtol=1e-12)
    assert draggy.power_w(2.0) > base.power_w(2.0)
    assert_allclose(
        draggy.power_w(2.0), reference_power_w(2.0, EnergyConfig(parcel_cda_m2=0.02)), rtol=1e-4
    )


def test_power_rises_with_payload(model):
    assert np.all(np.diff(model.table_w) > 0)


def test_one_model_per_drone_type_is_built_once():
    """EnergyModel.of shares one model per set of drone parameters (a copy of them, so a
    later change to the config object cannot change the shared model)."""
    from marops_cli.config import EnergyConfig
    from marops_cli.energy import EnergyModel

    a = EnergyConfig(max_payload_kg=1.5)
    m = EnergyModel.of(a)
    assert EnergyModel.of(EnergyConfig(max_payload_kg=1.5)) is m
    assert EnergyModel.of(EnergyConfig()) is not m
    a.max_payload_kg = 2.0
    assert m.max_payload_kg == 1.5 and EnergyModel.of(a).max_payload_kg == 2.0


def test_fits_at_and_just_over_the_limits() -> None:
    """The defaults: 2.5 kg payload, usable battery 225 kJ x (1 - 0.25) = 168,750 J; the
    tolerances are 1e-9 kg and 1e-6 J (docs/method.md, "Feasibility")."""
    m = EnergyModel()
    assert m.usable_j == 168_750.0 and m.max_payload_kg == 2.5
    assert m.fits(2.5) and m.fits(2.5 + 0.5e-9)
    assert not m.fits(2.5 + 2e-9) and not m.fits(2.6)
    assert m.fits(0.0, 168_750.0) and m.fits(2.5, 168_750.0 + 0.5e-6)
    assert not m.fits(0.0, 168_750.0 + 2e-6)
    assert not m.fits(2.5 + 2e-9, 100.0)  # both limits hold, not either
    assert m.fits(energy_j=168_750.0) and not m.fits(energy_j=168_751.0)
    got = m.fits(np.array([1.0, 2.5, 2.51]), np.array([1e5, 2e5, 1e5]))
    assert got.tolist() == [True, False, False]
