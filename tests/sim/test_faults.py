"""Faults: a second run into a busy folder, temporaries a killed run left, SIGTERM."""

from __future__ import annotations

import signal
from pathlib import Path

from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.io.atomic import folder_lock


def test_a_second_run_into_a_busy_folder_stops_with_a_message(example_csv: Path, tmp_path: Path):
    out = tmp_path / "day"
    args = ["replay-day", str(example_csv), "--date", "0811", "--method", "stay", "--out", str(out)]
    with folder_lock(out):  # another run holds the folder
        res = CliRunner().invoke(app, args)
    assert res.exit_code == 1
    assert "another marops run (pid" in res.stderr and "is writing here" in res.stderr
    assert not (out / "stops.parquet").exists()
    res = CliRunner().invoke(app, args)  # once it is free, the run goes through
    assert res.exit_code == 0, res.output
    assert not (out / ".marops.lock").exists()


def test_the_next_run_removes_temporaries_a_killed_run_left(example_csv: Path, tmp_path: Path):
    out = tmp_path / "week"
    stale = [
        out / ".metrics.json.marops-k1l2e3d4.tmp",
        out / "2022-08-11" / ".stops.parquet.marops-x9y8z7w6.tmp",
    ]
    kept = [  # not marops's name, or in a folder the run does not write
        out / ".metrics.json.k1l2e3d4.tmp",
        out / ".thesis-draft.tmp",
        out / "keep" / "deeper" / ".stops.parquet.marops-abcdefgh.tmp",
    ]
    for p in stale + kept:
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(b"half a file")
    args = ["replay-day", str(example_csv), "--dates", "0811..0812", "--method", "stay"]
    res = CliRunner().invoke(app, [*args, "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert not any(p.exists() for p in stale)
    assert all(p.read_bytes() == b"half a file" for p in kept)


def test_sigterm_exits_143_with_one_line_and_leaves_outputs_complete_or_absent(
    example_csv: Path, tmp_path: Path, stop_marops
):
    out = tmp_path / "week"
    args = ["replay-day", str(example_csv), "--dates", "0801..0812", "--method", "greedy"]
    ready = (out / "2022-08-01" / "metrics.json").exists
    code, err = stop_marops([*args, "--out", str(out), "-q"], ready, signal.SIGTERM, group=False)
    assert code == 143, err
    last = err.strip().splitlines()[-1]
    assert last.startswith("marops: terminated; ") and "of 12 days are written" in last
    assert "Traceback" not in err
    assert not list(out.rglob("*.tmp")) and not (out / ".marops.lock").exists()
    for day in (p for p in out.iterdir() if p.is_dir()):
        names = {p.name for p in day.iterdir()}
        # a day with metrics.json is complete; a day without it has no route files either
        assert names in ({"stops.parquet", "routes.parquet", "metrics.json"}, set()), names
