"""An evaluation over α writes its frontier (frontier.csv, summary.md) and the report
shows it (docs/outputs.md, "Frontier")."""

from __future__ import annotations

import math
from pathlib import Path

import pyarrow.csv as pv

from .conftest import figure


def test_an_evaluation_over_alpha_writes_the_frontier(evaluation_run: Path) -> None:
    import pyarrow.csv as pv

    front = pv.read_csv(evaluation_run / "frontier.csv").to_pylist()
    assert {(r["method"], r["alpha"]) for r in front} == {
        (m, a) for m in ("stay", "greedy") for a in (0.2, 0.8)
    }
    assert all(math.isfinite(r["energy_per_parcel_kj"]) for r in front)
    md = (evaluation_run / "summary.md").read_text(encoding="utf-8")
    assert "## Frontier over α" in md


def test_the_report_draws_the_frontier_open_where_dominated(evaluation_run: Path) -> None:
    page = (evaluation_run / "report.html").read_text(encoding="utf-8")
    data, layout = figure(page, "frontier")
    front = pv.read_csv(evaluation_run / "frontier.csv").to_pylist()
    assert len(data) == 4  # two methods, two panels
    drawn = {
        (t["name"], float(a)): s
        for t in data
        if t["showlegend"]
        for a, s in zip(t["text"], t["marker"]["symbol"], strict=True)
    }
    for r in front:
        open_ = drawn[(r["method"], r["alpha"])] == "circle-open"
        assert open_ == r["dominated"]
    assert "lower left is better" in str(layout)
