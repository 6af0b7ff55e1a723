"""City shapes of the generator: layouts and demand that moves over the map in a day."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest

from marops_cli.data.synth import SynthConfig, generate


def _xy_hours(t: pa.Table) -> tuple[np.ndarray, np.ndarray]:
    lng = t["lng"].to_numpy(zero_copy_only=False).astype(float)
    lat = t["lat"].to_numpy(zero_copy_only=False).astype(float)
    ok = np.isfinite(lng) & np.isfinite(lat) & (lng != 0)
    hh = np.array([int(s[6:8]) + int(s[9:11]) / 60 for s in t["delivery_time"].to_pylist()])
    x = (lng[ok] - 121.47) * 111.32 * np.cos(np.radians(31.23))
    y = (lat[ok] - 31.23) * 110.57
    return np.column_stack([x, y]), hh[ok]


def _morning_gap(xy: np.ndarray, hours: np.ndarray, axis: np.ndarray) -> float:
    """Share of peak deliveries before noon on one side of ``axis`` minus the other."""
    side = xy @ axis > 0
    peak = (hours > 7) & (hours < 18)
    am = hours < 12.5
    return abs(am[side & peak].mean() - am[~side & peak].mean())


@pytest.mark.parametrize("shape", ["river", "corridor", "polycentric"])
def test_shapes_are_deterministic_and_differ_from_hubs(shape: str) -> None:
    a = generate(SynthConfig(days=2, seed=3, shape=shape))
    assert a.equals(generate(SynthConfig(days=2, seed=3, shape=shape)))
    assert not a.equals(generate(SynthConfig(days=2, seed=3)))
    assert a.column_names == generate(SynthConfig(days=1, seed=3)).column_names


def test_corridor_is_long_and_its_peak_moves_along_it() -> None:
    xy, hours = _xy_hours(generate(SynthConfig(days=3, seed=5, shape="corridor")))
    w, v = np.linalg.eigh(np.cov((xy - xy.mean(axis=0)).T))
    assert np.sqrt(w[1] / w[0]) > 2.5  # the long axis is over 2.5 times the short one
    assert _morning_gap(xy, hours, v[:, 1]) > 0.15


def test_river_leaves_a_band_empty_and_its_banks_keep_different_hours() -> None:
    xy, hours = _xy_hours(generate(SynthConfig(days=3, seed=6, shape="river")))
    # Find the band: among directions, the one whose central 1 km strip is emptiest.
    best = min(
        (np.mean(np.abs(xy @ np.array([-np.sin(a), np.cos(a)])) < 0.4), a)
        for a in np.linspace(0, np.pi, 180, endpoint=False)
    )
    assert best[0] < 0.01  # < 1 % of deliveries in the strip (GPS noise and AOI radii)
    normal = np.array([-np.sin(best[1]), np.cos(best[1])])
    assert _morning_gap(xy, hours, normal) > 0.3


def test_hubs_keep_one_profile_everywhere() -> None:
    xy, hours = _xy_hours(generate(SynthConfig(days=3, seed=5)))
    for a in np.linspace(0, np.pi, 6, endpoint=False):
        assert _morning_gap(xy, hours, np.array([np.cos(a), np.sin(a)])) < 0.06
