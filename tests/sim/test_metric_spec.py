"""One spec of the day-metric columns (sim/metrics.py): the tables take their columns,
labels and formats from it, and docs/outputs.md describes every one of them."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from marops_cli.sim.metrics import (
    COMBINED_COST,
    DAILY_COMBINED_COST,
    DAY_METRICS,
    METRICS,
    OPS_METRICS,
    metric_names,
)

DOCS = Path(__file__).resolve().parents[2] / "docs" / "outputs.md"


def test_names_are_unique_and_unknown_names_fail() -> None:
    names = [m.name for m in (*DAY_METRICS, *OPS_METRICS, COMBINED_COST, DAILY_COMBINED_COST)]
    assert len(names) == len(set(names)) == len(METRICS)
    with pytest.raises(KeyError):
        metric_names("avg_delay")


def test_docs_describe_every_column_with_its_unit() -> None:
    text = DOCS.read_text(encoding="utf-8")
    section = text.split("## Day metrics")[1].split("\n## ")[0]
    units = {}
    for row in re.findall(r"^\| (`.+?) \| (.*?) \|", section, flags=re.M):
        for name in re.findall(r"`(\w+)`", row[0]):
            units[name] = row[1]
    for m in (*DAY_METRICS, *OPS_METRICS, COMBINED_COST, DAILY_COMBINED_COST):
        assert f"`{m.name}`" in text, m.name
        if m.name in units:
            assert units[m.name] == m.unit, m.name
    # all but solver_* and the comparisons
    assert len(units.keys() & METRICS.keys()) == 25 + len(OPS_METRICS)


def test_summary_tables_follow_the_spec() -> None:
    """summary.md / Table III rows: the spec's labels and formats (the report's text)."""
    from marops_cli.evaluate.paired import PAIRED_METRICS
    from marops_cli.evaluate.report import TABLE_ROWS
    from marops_cli.evaluate.tables import SUMMARY_METRICS

    assert all(r is METRICS[r.name] for r in TABLE_ROWS)
    assert [(r.name, r.label, r.fmt) for r in TABLE_ROWS] == [
        ("mean_energy_kj", "Mean energy consumption (kJ)", "{:.1f}"),
        ("avg_delay_h", "Average delivery delay (h)", "{:.2f}"),
        ("combined_cost", "Combined cost", "{:.2f}"),
        ("delay_unfairness", "Delay unfairness", "{:.2f}"),
        ("runtime_s", "Average running time (s)", "{:.2f}"),
        ("avg_early_h", "Average early arrival (h)", "{:.2f}"),
        ("co2_g", "CO2 per day (g)", "{:.0f}"),
        ("delivered", "Delivered per day", "{:.1f}"),
        ("undelivered", "Undelivered per day", "{:.1f}"),
        ("delivered_share", "Delivered share", "{:.3f}"),
        ("objective_j_mj", "Day objective J (MJ)", "{:.2f}"),
        ("objective_g_mj", "Day objective G (MJ)", "{:.2f}"),
        ("battery_frac_mean", "Battery used per flight", "{:.2f}"),
        ("actions_stay", "Decisions to stay", "{:.3f}"),
        ("actions_move", "Decisions to move", "{:.3f}"),
        ("actions_free", "Decisions to land freely", "{:.3f}"),
        ("waiting_max", "Most parcels waiting at a depot", "{:.1f}"),
        ("actions_idle", "Drone-windows held back", "{:.3f}"),
        ("battery_waits", "Windows waited for a battery", "{:.1f}"),
    ]
    assert set(SUMMARY_METRICS) <= METRICS.keys() and len(SUMMARY_METRICS) == 22
    assert PAIRED_METRICS == {
        "objective_j_mj": True,
        "delivered_share": False,
        "avg_delay_h": True,
        "mean_energy_kj": True,
        "combined_cost": True,
    }


def test_day_tables_follow_the_spec() -> None:
    """replay-day's table and the sweep figures name only columns of the spec."""
    from marops_cli.app.replay import SUMMED
    from marops_cli.cli.replay_cmd import METRIC_COLUMNS
    from marops_cli.evaluate.plots import PANELS

    heads = [(METRICS[k].header, METRICS[k].day_fmt) for k in METRIC_COLUMNS]
    assert heads == [
        ("energy kJ/drone", "{:.1f}"),
        ("delay h", "{:.3f}"),
        ("unfairness", "{:.3f}"),
        ("early h", "{:.3f}"),
        ("delivered", "{}"),
        ("undelivered", "{}"),
        ("J MJ", "{:.2f}"),
        ("G MJ", "{:.2f}"),
        ("CO2 g", "{:.1f}"),
        ("runtime s", "{:.3f}"),
    ]
    assert set(SUMMED) <= METRICS.keys()
    panels = {m for p in PANELS.values() for m, _ in p} - {"depot_load"}
    assert panels <= METRICS.keys()
