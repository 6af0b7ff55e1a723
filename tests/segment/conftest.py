"""Shared fixtures of the segmentation tests."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

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


def moved_example(example_csv: Path, out: Path, place) -> Path:  # noqa: ANN001
    """The example's first 300 rows written to ``out`` with row k at ``place(k)``, a
    (lng, lat) pair: a town of one's own shape from real rows. A row repeating an
    earlier one (the example has exact repeats) goes where that one went, and stays a
    repeat the reader drops."""
    lines = example_csv.read_text().splitlines()
    head = lines[0].split(",")
    ilng, ilat, iid = head.index("lng"), head.index("lat"), head.index("order_id")
    rows = []
    first: dict[str, int] = {}
    for k, line in enumerate(lines[1:301]):
        cells = line.split(",")
        lng, lat = place(first.setdefault(cells[iid], k))
        cells[ilng], cells[ilat] = f"{lng:.6f}", f"{lat:.6f}"
        rows.append(",".join(cells))
    out.write_text("\n".join([lines[0], *rows]) + "\n")
    return out
