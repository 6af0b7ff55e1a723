"""Several days in one call: a folder per day, one metrics.json, resume after a kill."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
from typer.testing import CliRunner

from marops_cli.cli.app import app

runner = CliRunner()


def _replay(example_csv: Path, out: Path, *extra: str) -> None:
    res = runner.invoke(
        app,
        [
            "replay-day",
            str(example_csv),
            "--dates",
            "0811..0812",
            "--method",
            "greedy",
            "--out",
            str(out),
            *extra,
        ],
    )
    assert res.exit_code == 0, res.output


def test_dates_layout_and_resume(example_csv: Path, tmp_path: Path) -> None:
    out = tmp_path / "week"
    _replay(example_csv, out)
    for day in ("2022-08-11", "2022-08-12"):
        folder = out / day
        assert {p.name for p in folder.iterdir()} == {
            "stops.parquet",
            "routes.parquet",
            "metrics.json",
        }
    top = json.loads((out / "metrics.json").read_text())
    assert [d["day"] for d in top["days"]] == ["2022-08-11", "2022-08-12"]
    # A killed run left day 2 unfinished: only day 2 is replayed, day 1 is kept as it was.
    day1 = out / "2022-08-11" / "stops.parquet"
    mtime = day1.stat().st_mtime_ns
    (out / "2022-08-12" / "metrics.json").unlink()
    _replay(example_csv, out)
    assert day1.stat().st_mtime_ns == mtime
    assert (out / "2022-08-12" / "metrics.json").is_file()
    again = json.loads((out / "metrics.json").read_text())
    assert again["days"] == top["days"][:1] + again["days"][1:]
    assert again["days"][1]["delivered"] == top["days"][1]["delivered"]
    # --force replays everything.
    _replay(example_csv, out, "--force")
    assert day1.stat().st_mtime_ns != mtime


def test_json_format_matches_parquet(example_csv: Path, tmp_path: Path) -> None:
    for fmt in ("parquet", "json"):
        res = runner.invoke(
            app,
            [
                "replay-day",
                str(example_csv),
                "--date",
                "0812",
                "--method",
                "ops-random",
                "--format",
                fmt,
                "--out",
                str(tmp_path / fmt),
            ],
        )
        assert res.exit_code == 0, res.output
    doc = json.loads((tmp_path / "json" / "stops.json").read_text())
    assert doc["meta"]["method"] == "ops-random"
    table = pq.read_table(tmp_path / "parquet" / "stops.parquet").to_pylist()
    assert len(doc["stops"]) == len(table)
    assert [r["order_id"] for r in doc["stops"]] == [r["order_id"] for r in table]
    assert [r["leg_j"] for r in doc["stops"]] == [r["leg_j"] for r in table]
    routes = json.loads((tmp_path / "json" / "routes.json").read_text())["routes"]
    assert len(routes) == 8 * 16
