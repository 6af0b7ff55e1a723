"""The local equirectangular frame and the densest-square study area."""

from __future__ import annotations

import numpy as np
import pytest

from marops_cli.data.frame import EARTH_RADIUS_M, Frame, densest_square
from marops_cli.errors import SettingError


def haversine_m(lng1, lat1, lng2, lat2) -> np.ndarray:
    p1, p2 = np.radians(lat1), np.radians(lat2)
    dp, dl = p2 - p1, np.radians(np.asarray(lng2) - np.asarray(lng1))
    a = np.sin(dp / 2) ** 2 + np.cos(p1) * np.cos(p2) * np.sin(dl / 2) ** 2
    return 2 * EARTH_RADIUS_M * np.arcsin(np.sqrt(a))


def test_round_trip() -> None:
    f = Frame(121.47, 31.23, 10.0)
    rng = np.random.default_rng(0)
    lng = 121.47 + rng.uniform(-0.1, 0.1, 1000)
    lat = 31.23 + rng.uniform(-0.1, 0.1, 1000)
    x, y = f.to_xy(lng, lat)
    back_lng, back_lat = f.to_lnglat(x, y)
    np.testing.assert_allclose(back_lng, lng, rtol=0, atol=1e-10)  # ~10 um
    np.testing.assert_allclose(back_lat, lat, rtol=0, atol=1e-10)
    np.testing.assert_allclose(f.to_xy(np.array([121.47]), np.array([31.23])), [[0], [0]])


@pytest.mark.parametrize("center_lat", [22.5, 31.23, 39.9, 45.0])
def test_equirectangular_error_under_0_1_percent(center_lat: float) -> None:
    """Distances between points of a 10 km square: planar vs great-circle within 0.1 %."""
    f = Frame(121.47, center_lat, 10.0)
    rng = np.random.default_rng(1)
    x = rng.uniform(-5000, 5000, (2, 4000))
    y = rng.uniform(-5000, 5000, (2, 4000))
    lng, lat = f.to_lnglat(x, y)
    planar = np.hypot(x[0] - x[1], y[0] - y[1])
    sphere = haversine_m(lng[0], lat[0], lng[1], lat[1])
    keep = sphere > 100.0  # relative error of very short legs is noise on tiny numbers
    rel = np.abs(planar[keep] - sphere[keep]) / sphere[keep]
    assert rel.max() < 1e-3
    # The corner-to-corner diagonal (~14 km) as well.
    clng, clat = f.to_lnglat(np.array([-5000.0, 5000.0]), np.array([-5000.0, 5000.0]))
    d = haversine_m(clng[0], clat[0], clng[1], clat[1])
    np.testing.assert_allclose(d, np.hypot(10_000, 10_000), rtol=1e-3)


def test_contains_edges() -> None:
    f = Frame(121.47, 31.23, 10.0)
    x = np.array([0.0, 5000.0, -5000.0, 5000.1, 0.0])
    y = np.array([0.0, 5000.0, 0.0, 0.0, -5000.1])
    np.testing.assert_array_equal(f.contains(x, y), [True, True, True, False, False])


def test_densest_square_finds_the_cluster() -> None:
    rng = np.random.default_rng(2)
    ref = Frame(121.47, 31.23, 10.0)
    # 3000 points spread over 40 km, and 1500 in a 1 km cluster 12 km east, 6 km north.
    sx, sy = rng.uniform(-20_000, 20_000, (2, 3000))
    cx, cy = 12_000 + rng.normal(0, 1000, 1500), 6_000 + rng.normal(0, 1000, 1500)
    lng, lat = ref.to_lnglat(np.r_[sx, cx], np.r_[sy, cy])
    frame = densest_square(lng, lat, 5.0, 250.0)
    fx, fy = ref.to_xy(np.array([frame.center_lng]), np.array([frame.center_lat]))
    np.testing.assert_allclose([fx[0], fy[0]], [12_000, 6_000], atol=1000)
    assert frame.size_km == 5.0
    assert densest_square(lng, lat, 5.0, 250.0) == frame  # reproducible


@pytest.mark.parametrize(
    ("span_x", "span_y"), [(4_000, 4_000), (0.0, 0.0), (12_000, 300.0), (300.0, 9_000)]
)
def test_a_town_smaller_than_the_square_sits_in_its_middle(span_x: float, span_y: float) -> None:
    """Every square around a town narrower than the study square holds it all: the
    square is the middle one of those, so the town's edges are as far from the square's
    as the grid allows (before, the south-west-most: the town in its corner, and a
    replay day's request a few metres south or west of the history left out). Along an
    axis the town fills (12 km), the square is the densest as before."""
    rng = np.random.default_rng(3)
    ref = Frame(121.47, 31.23, 10.0)
    x = 2_000 + rng.uniform(0, span_x, 500)
    y = -1_000 + rng.uniform(0, span_y, 500)
    lng, lat = ref.to_lnglat(x, y)
    frame = densest_square(lng, lat, 10.0, 250.0)
    fx, fy = ref.to_xy(np.array([frame.center_lng]), np.array([frame.center_lat]))
    tx, ty = ref.to_xy(lng, lat)
    for axis, (f, t) in enumerate(((fx[0], tx), (fy[0], ty))):
        if (span_x, span_y)[axis] > 10_000:
            continue  # wider than the square: no square holds it all
        low, high = t.min() - (f - 5_000), (f + 5_000) - t.max()  # margins, m
        assert min(low, high) >= 0, (axis, low, high)
        assert abs(low - high) <= 2 * 250.0 + 1e-6, (axis, low, high)  # within a cell


def test_densest_square_empty() -> None:
    with pytest.raises(ValueError):
        densest_square(np.array([]), np.array([]), 10.0)


def test_a_grid_too_fine_for_the_city_names_the_step() -> None:
    """A 10 m step over requests 100 km apart would count 10⁸ cells (gigabytes): one
    error naming data.grid_m and a step that fits, before any allocation."""
    lng = np.array([121.0, 121.0 + 100_000.0 / (EARTH_RADIUS_M * np.pi / 180.0) / 0.85])
    lat = np.array([31.0, 31.5])
    with pytest.raises(SettingError) as err:
        densest_square(lng, lat, 5.0, 10.0)
    assert err.value.key == "data.grid_m" and "a step of at least" in str(err.value)
    assert densest_square(lng, lat, 5.0, 250.0).size_km == 5.0  # the default step is fine


def test_a_city_across_the_antimeridian_is_one_study_area() -> None:
    """Requests on both sides of 180° lie side by side: the densest square holds them
    all, and positions map back to longitudes in -180..180."""
    rng = np.random.default_rng(3)
    east = 179.99 + rng.uniform(-0.005, 0.005, 500)
    west = -179.99 + rng.uniform(-0.005, 0.005, 500)  # evenly split: the plain median is 0
    lng, lat = np.r_[east, west], -16.8 + rng.uniform(-0.01, 0.01, 1000)
    f = densest_square(lng, lat, 10.0)
    assert abs(f.center_lng) > 179.9
    x, y = f.to_xy(lng, lat)
    assert f.contains(x, y).sum() >= 995  # both sides (the square's very edge aside)
    back, _ = f.to_lnglat(x, y)
    np.testing.assert_allclose(back, lng, rtol=0, atol=1e-9)
    assert np.abs(back).max() <= 180.0
    # 0.02° of longitude apart across the line, as two points 0.02° apart elsewhere.
    x2, _ = Frame(180.0, -16.8, 10.0).to_xy(np.array([179.99, -179.99]), np.array([0.0, 0.0]))
    np.testing.assert_allclose(x2[1] - x2[0], 0.02 * Frame(0, -16.8, 1)._kx, rtol=1e-9)


def test_longitudes_away_from_the_antimeridian_map_as_before() -> None:
    f = Frame(121.47, 31.23, 10.0)
    lng = 121.47 + np.random.default_rng(0).uniform(-0.2, 0.2, 1000)
    x, _ = f.to_xy(lng, np.zeros(1000))
    assert x.tobytes() == ((lng - 121.47) * f._kx).tobytes()
    back, _ = f.to_lnglat(x, np.zeros(1000))
    assert back.tobytes() == (x / f._kx + 121.47).tobytes()
