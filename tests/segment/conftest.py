"""Shared fixtures of the segmentation tests."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from marops_cli.data.table import DropReport, LadeTable, SourceInfo


def _points_table(lng: np.ndarray, lat: np.ndarray, sha256: str = "0") -> LadeTable:
    """A kept table of orders at these points, all due at time 0, from file ``x.csv``."""
    n = len(lng)
    return LadeTable(
        order_id=np.array([f"o{i}" for i in range(n)], dtype=object),
        lng=np.asarray(lng, dtype=np.float64),
        lat=np.asarray(lat, dtype=np.float64),
        accept_s=np.zeros(n, np.int64),
        delivery_s=np.zeros(n, np.int64),
        aoi_id=np.array([""] * n, dtype=object),
        weight_kg=None,
        row=np.arange(2, n + 2),
        source=SourceInfo("x.csv", "x.csv", 0, sha256),
        report=DropReport(n, n),
    )


@pytest.fixture
def points_table() -> Callable[..., LadeTable]:
    """``points_table(lng, lat, sha256="0")``: a small LadeTable of orders at points."""
    return _points_table
