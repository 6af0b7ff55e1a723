"""Result tables on an 80-column terminal: every number whole (no ``15…``, ``0.…``)."""

from __future__ import annotations

import io

import pyarrow as pa
import pytest
from rich.console import Console

from marops_cli.cli import common
from marops_cli.cli.fit import fit_table


@pytest.fixture
def terminal(monkeypatch: pytest.MonkeyPatch) -> io.StringIO:
    """stdout as an 80-column terminal (rich boxes, no colour codes to strip)."""
    buf = io.StringIO()
    console = Console(file=buf, width=80, force_terminal=True, color_system=None)
    monkeypatch.setattr(common, "out", console)
    monkeypatch.setattr(common, "PLAIN", False)
    monkeypatch.setitem(common.STATE, "json", False)
    monkeypatch.setitem(common.STATE, "quiet", False)  # as an earlier --quiet run left it
    return buf


def _whole(text: str, cells: list[str]) -> None:
    assert "…" not in text
    assert max(len(line) for line in text.splitlines()) <= 80
    for cell in cells:
        assert cell in text, cell


def test_replay_day_metrics_fit_80_columns(terminal: io.StringIO) -> None:
    from marops_cli.cli.replay_cmd import METRIC_COLUMNS, _print_metrics
    from marops_cli.sim.metrics import metric_specs

    row = {"day": "2022-08-11", "method": "ops-global", "hub": 3}
    row |= {s.name: 15123.456789 for s in metric_specs(*METRIC_COLUMNS)}
    _print_metrics([row, row | {"day": "2022-08-12"}], hubs=True)
    cells = [s.day_fmt.format(row[s.name]) for s in metric_specs(*METRIC_COLUMNS)]
    text = terminal.getvalue()
    _whole(text, cells)
    # every part repeats the keys that name a row
    parts = text.count("day metrics")
    assert parts > 1 and text.count("2022-08-12") == parts and text.count("ops-global") == 2 * parts


def test_paired_table_fits_and_names_settings_and_columns(terminal: io.StringIO) -> None:
    from marops_cli.cli.evaluate_cmd import _print_paired

    summary = pa.table(
        {
            "setting": [0, 1],
            "alpha": [0.3, 0.8],
            "drones": [8, 8],
            "coverage": [0.25, 0.25],
            "depots_n": [16, 16],
        }
    )
    paired = [
        {
            "setting": s,
            "method": "ops-random",
            "against": "myopic",
            "metric": "objective_j_mj",
            "days": 12,
            "mean_diff": -333.812345,
            "ci_low": -412.55555,
            "ci_high": -255.12121,
            "days_better": 11,
            "lower_is_better": True,
            "few_days": False,
        }
        for s in (0, 1)
    ]
    _print_paired(pa.Table.from_pylist(paired), summary)
    text = terminal.getvalue()
    _whole(text, ["-333.8", "[-412.6, -255.1]", "11/12", "better"])
    assert "α=0.3" in text and "α=0.8" in text  # settings by their values, not 0 / 1
    assert "verdict" in text  # every column named


def test_fit_table_keeps_a_table_that_fits_whole() -> None:
    t = common.table("small")
    for name in ("a", "b"):
        t.add_column(name)
    t.add_row("1", "2")
    (same,) = fit_table(t, 80)
    assert [c.header for c in same.columns] == ["a", "b"] and same.title == "small"


def test_plain_output_is_never_split(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without a terminal a table stays one, its lines as long as they need."""
    buf = io.StringIO()
    monkeypatch.setattr(common, "out", Console(file=buf, width=1000, no_color=True))
    monkeypatch.setattr(common, "PLAIN", True)
    monkeypatch.setitem(common.STATE, "json", False)
    monkeypatch.setitem(common.STATE, "quiet", False)
    t = common.table("wide")
    for i in range(30):
        t.add_column(f"column {i}")
    t.add_row(*[f"{i * 1234.5678:.3f}" for i in range(30)])
    common.show_table(t)
    assert buf.getvalue().count("wide") == 1 and "…" not in buf.getvalue()
