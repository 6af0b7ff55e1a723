"""Paired comparisons against a reference method, by hand and through the CLI."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.evaluate.paired import bootstrap_ci, paired_table, verdict


def test_bootstrap_ci_by_hand() -> None:
    assert bootstrap_ci(np.array([0.3, 0.3, 0.3])) == pytest.approx((0.3, 0.3))  # no spread
    assert bootstrap_ci(np.array([2.0])) == (2.0, 2.0)
    lo, hi = bootstrap_ci(np.array([-1.0, 0.0, 1.0, 2.0]))
    assert -1.0 <= lo < 0.5 < hi <= 2.0  # around the mean 0.5, inside the data's range
    assert bootstrap_ci(np.array([-1.0, 0.0, 1.0, 2.0])) == (lo, hi)  # seeded: reproducible


def _results(j_a: list[float], j_b: list[float]) -> pa.Table:
    rows = []
    for method, js in (("ref", j_a), ("new", j_b)):
        for d, j in enumerate(js):
            rows.append(
                {
                    "setting": 0,
                    "method": method,
                    "day": f"2022-08-{11 + d}",
                    "repeat": 0,
                    "objective_j_mj": j,
                    "delivered_share": 0.9,
                    "avg_delay_h": 0.5,
                    "mean_energy_kj": 1000.0,
                    "combined_cost": 0.5,
                }
            )
    return pa.Table.from_pylist(rows)


def test_paired_table_by_hand() -> None:
    """new − ref on J: -10, -20, +3 → mean -9, two days better, a zero-crossing CI."""
    table = paired_table(_results([100.0, 200.0, 50.0], [90.0, 180.0, 53.0]), "ref")
    row = next(r for r in table.to_pylist() if r["metric"] == "objective_j_mj")
    assert (row["method"], row["days"], row["days_better"]) == ("new", 3, 2)
    assert row["mean_diff"] == pytest.approx(-9.0)
    assert row["ci_low"] < 0 < row["ci_high"] and row["few_days"] is True
    assert verdict(row) == "too few days (n=3)"  # not "no difference" from three days
    same = next(r for r in table.to_pylist() if r["metric"] == "delivered_share")
    assert same["mean_diff"] == 0 and (same["ci_low"], same["ci_high"]) == (0, 0)
    # a difference on every day of one sign is a verdict
    worse = paired_table(_results([100.0] * 12, [110.0 + i for i in range(12)]), "ref")
    row = next(r for r in worse.to_pylist() if r["metric"] == "objective_j_mj")
    assert verdict(row) == "worse" and row["few_days"] is False
    # The same differences over nine days: the interval excludes zero, yet no verdict.
    few = paired_table(_results([100.0] * 9, [110.0 + i for i in range(9)]), "ref")
    row = next(r for r in few.to_pylist() if r["metric"] == "objective_j_mj")
    assert row["ci_low"] > 0 and row["few_days"] is True
    assert verdict(row) == "too few days (n=9)"
    # ten days: a verdict again
    ten = paired_table(_results([100.0] * 10, [110.0 + i for i in range(10)]), "ref")
    row = next(r for r in ten.to_pylist() if r["metric"] == "objective_j_mj")
    assert verdict(row) == "worse" and row["few_days"] is False


def test_repeats_of_one_day_are_one_paired_day() -> None:
    """Two repeats of one day are one day's draws: one difference (their mean, by hand:
    new − ref = -10 and -20 → -15), one day, flagged few, no verdict from one day."""
    rows = []
    for method, js in (("ref", [100.0, 200.0]), ("new", [90.0, 180.0])):
        for repeat, j in enumerate(js):
            row = dict.fromkeys(("delivered_share", "avg_delay_h", "mean_energy_kj"), 1.0)
            rows.append(
                {"setting": 0, "method": method, "day": "2022-08-11", "repeat": repeat}
                | row
                | {"objective_j_mj": j, "combined_cost": 0.5}
            )
    table = paired_table(pa.Table.from_pylist(rows), "ref")
    row = next(r for r in table.to_pylist() if r["metric"] == "objective_j_mj")
    assert (row["days"], row["days_better"], row["few_days"]) == (1, 1, True)
    assert row["mean_diff"] == pytest.approx(-15.0)
    assert (row["ci_low"], row["ci_high"]) == pytest.approx((-15.0, -15.0))
    assert verdict(row) == "too few days (n=1)"


def test_evaluate_against_writes_paired_csv_and_warns_on_few_days(
    example_csv: Path, tmp_path: Path
) -> None:
    out = tmp_path / "ev"
    args = ["evaluate", "--area", "square", str(example_csv), "--methods", "stay,greedy"]
    args += ["--dates", "0811..0812"]
    res = CliRunner().invoke(app, [*args, "--against", "stay", "--no-plot", "--out", str(out)])
    assert res.exit_code == 0, res.output
    rows = list(csv.DictReader((out / "paired.csv").open()))
    assert {r["method"] for r in rows} == {"greedy"} and {r["against"] for r in rows} == {"stay"}
    assert {r["metric"] for r in rows} >= {"objective_j_mj", "delivered_share", "avg_delay_h"}
    assert all(r["days"] == "2" for r in rows)
    assert "warning: only 2 days back the paired comparison" in res.stderr
    assert res.stderr.count("warning: only 2 days") == 1  # one warning, not the summary's too
    assert "paired against stay" in res.stdout
    # no verdict word from two days: each row says why
    assert res.stdout.count("too few days (n=2)") == len(rows)
    ends = ("better", "worse", "no difference")
    assert not [line for line in res.stdout.splitlines() if line.rstrip().endswith(ends)]
    summary = list(csv.DictReader((out / "summary.csv").open()))
    assert {(r["calendar_days"], r["few_days"]) for r in summary} == {("2", "true")}
    assert "**Only 2 days back the comparison (fewer than 10)" in (out / "summary.md").read_text()


def test_evaluate_without_against_warns_on_few_days(example_csv: Path, tmp_path: Path) -> None:
    """Without --against the summary's means compare the methods: over two days the
    command warns they establish no difference, and summary.md and summary.csv say so."""
    out = tmp_path / "ev"
    args = ["evaluate", str(example_csv), "--area", "square", "--methods", "stay,greedy"]
    args += ["--dates", "0811..0812"]
    res = CliRunner().invoke(app, [*args, "--no-plot", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert res.stderr.count("warning: only 2 days back the comparison (fewer than 10)") == 1
    summary = list(csv.DictReader((out / "summary.csv").open()))
    assert [(r["n"], r["calendar_days"], r["few_days"]) for r in summary] == [
        ("2", "2", "true")
    ] * 2
    assert "**Only 2 days back the comparison" in (out / "summary.md").read_text()
    assert not (out / "paired.csv").exists()


def _city(hubs: int, days: int, repeats: int) -> pa.Table:
    """Results of stay and greedy over ``hubs`` hubs and ``days`` days; greedy's J 10 MJ
    above stay's on every hub-day."""
    return pa.Table.from_pylist(
        [
            {"setting": 0, "alpha": 0.5, "drones": 8, "coverage": 0.25, "depots_n": 16}
            | {"n_actions": 4, "segmentation": "kmeans", "method": m, "hub": h}
            | {"day": f"2022-08-{1 + d:02d}", "repeat": r, "objective_j_mj": 1.0 + d + 10 * k}
            | dict.fromkeys(("delivered_share", "avg_delay_h", "mean_energy_kj"), 1.0)
            | {"combined_cost": 0.5 + 0.01 * h}
            for k, m in enumerate(("stay", "greedy"))
            for h in range(hubs)
            for d in range(days)
            for r in range(repeats)
        ]
    )


def test_a_citys_hubs_on_one_day_are_one_day() -> None:
    """Twelve hubs over two days are 24 paired hub-days but two calendar days: no
    verdict and a warning, in the summary as in the paired comparison; ten days give
    a verdict."""
    from marops_cli.evaluate.paired import few_days_warning
    from marops_cli.evaluate.tables import summarize

    city = _city(hubs=12, days=2, repeats=2)
    row = summarize(city).to_pylist()[0]
    assert (row["n"], row["calendar_days"], row["few_days"]) == (48, 2, True)
    assert "only 2 days back the comparison" in (few_days_warning(summarize(city)) or "")
    j = next(r for r in paired_table(city, "stay").to_pylist() if r["metric"] == "objective_j_mj")
    assert (j["days"], j["calendar_days"], j["few_days"]) == (24, 2, True)
    assert j["ci_low"] > 0 and verdict(j) == "too few days (n=2)"
    assert "only 2 days (24 hub-days) back the paired comparison" in (
        few_days_warning(paired_table(city, "stay")) or ""
    )
    ten = _city(hubs=2, days=10, repeats=1)
    assert summarize(ten).column("few_days").to_pylist() == [False, False]
    assert few_days_warning(summarize(ten)) is None
    j = next(r for r in paired_table(ten, "stay").to_pylist() if r["metric"] == "objective_j_mj")
    assert (j["days"], j["calendar_days"]) == (20, 10) and verdict(j) == "worse"
