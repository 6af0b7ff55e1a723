"""The one nearest-depot rule (service areas, free landings, the last leg of a route)."""

from __future__ import annotations

import numpy as np

from marops_cli.data.frame import Frame
from marops_cli.segment.depots import Depots, nearest_candidates, nearest_depot

XY = np.array([[0.0, 0.0], [2000.0, 0.0], [1000.0, 1000.0], [1000.0, -1000.0]])


def test_ties_go_to_the_lower_depot_id() -> None:
    # (1000, 0) is 1000 m from all four depots; (0, 1000) is as far from 0 as from 2.
    ids, dist = nearest_depot(np.array([[1000.0, 0.0], [0.0, 1000.0], [1500.0, -600.0]]), XY)
    assert ids.tolist() == [0, 0, 3]
    assert dist[:2].tolist() == [1000.0, 1000.0]
    assert abs(dist[2] - np.hypot(500.0, 400.0)) < 1e-9


def test_one_point_and_no_points() -> None:
    ids, dist = nearest_depot(np.array([1900.0, 50.0]), XY)
    assert ids.tolist() == [1] and abs(dist[0] - np.hypot(100.0, 50.0)) < 1e-9
    ids, dist = nearest_depot(np.zeros((0, 2)), XY)
    assert ids.size == 0 and dist.size == 0


def test_chunks_change_nothing_and_areas_are_nearest_depots() -> None:
    # More points than one chunk holds (2,000,000 // 4 depots), on a grid with many ties.
    g = np.arange(-500.0, 2500.0, 4.0)
    pts = np.array(np.meshgrid(g, g[:700])).reshape(2, -1).T
    assert pts.shape[0] > 2_000_000 // len(XY)
    ids, dist = nearest_depot(pts, XY)
    d = np.hypot(pts[:, None, 0] - XY[None, :, 0], pts[:, None, 1] - XY[None, :, 1])
    assert np.array_equal(ids, np.argmin(d, axis=1))
    assert np.array_equal(dist, d.min(axis=1))
    frame = Frame(121.47, 31.23, 10.0)
    dep = Depots("kmeans", frame, XY, np.zeros(4, np.int64), nearest_candidates(XY, 2))
    assert np.array_equal(dep.assign(pts[:, 0], pts[:, 1]), ids)
