"""The report in a real browser (headless Chromium over the DevTools protocol): the map
holds one line per route, the page logs no error, and a screenshot is taken. Skipped only
where no Chromium is on PATH; .ci/run installs the distribution's package."""

from __future__ import annotations

import os
import struct
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from marops_cli.report.basemap import TILE_HOST

from .cdp import chromium, open_page

pytestmark = pytest.mark.skipif(chromium() is None, reason="no chromium on PATH")

_MAP = "document.getElementById('map')"
READY = (
    f"typeof Plotly !== 'undefined' && !!{_MAP} && {_MAP}._fullLayout !== undefined"
    " && !!document.querySelector('#timeline .bars')"
)
ROUTE_LINES = "#map g.trace.scatter[class*='traceroute-'] path.js-line"


def _png_size(data: bytes) -> tuple[int, int]:
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


def test_report_in_chromium(day_run: Path, tmp_path: Path) -> None:
    shot = Path(os.environ.get("MAROPS_REPORT_SCREENSHOT", tmp_path / "report.png"))
    run = open_page(
        (day_run / "report.html").as_uri(),
        ready=READY,
        expressions={
            "drawn": f'document.querySelectorAll("{ROUTE_LINES}").length',
            "traces": f"{_MAP}.data.filter(t => (t.uid || '').startsWith('route-')).length",
            "slider": "document.querySelectorAll('#map .slider-container').length",
            "bars": "document.querySelectorAll('#timeline .bars .point').length",
        },
        screenshot=shot,
    )
    routes = pq.read_table(day_run / "routes.parquet").to_pylist()
    flown = sum(r["n_parcels"] > 0 or r["start_depot"] != r["end_depot"] for r in routes)
    assert run.values["traces"] == flown
    assert run.values["drawn"] == flown  # one drawn line per route
    assert run.values["slider"] == 1
    assert run.values["bars"] >= flown
    # Offline the map tiles fail to load (the service areas stay the map); nothing else may.
    errors = [
        e
        for e in run.errors
        if not (e["source"] == "network" and str(e.get("url", "")).startswith(TILE_HOST))
    ]
    assert errors == []
    width, height = _png_size(shot.read_bytes())
    assert (width, height) == (1300, 1000)
