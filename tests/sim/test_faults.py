"""Faults: a second run into a busy folder, temporaries a killed run left, SIGTERM."""

from __future__ import annotations

import signal
from pathlib import Path

from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.io.atomic import folder_lock

# One study square: its files in --out, or in a folder per day (a city's, per hub below).
SQUARE = ["--area", "square"]


def test_a_second_run_into_a_busy_folder_stops_with_a_message(example_csv: Path, tmp_path: Path):
    out = tmp_path / "day"
    args = ["replay-day", *SQUARE, str(example_csv), "--date", "0811", "--method", "stay"]
    args += ["--out", str(out)]
    with folder_lock(out):  # another run holds the folder
        res = CliRunner().invoke(app, args)
    assert res.exit_code == 1
    assert "another marops run (pid" in res.stderr and "is writing here" in res.stderr
    assert not (out / "stops.parquet").exists()
    res = CliRunner().invoke(app, args)  # once it is free, the run goes through
    assert res.exit_code == 0, res.output
    assert not (out / ".marops.lock").exists()


# A run killed (kill -9) while it writes temporaries under its folder: it takes the
# folder's lock, makes one temporary in the folder and one in a day's folder, says so
# and waits to be killed.
KILLED = """
import sys
from pathlib import Path
from marops_cli.io import folder_lock, output_set
out = Path(sys.argv[1])
with folder_lock(out), output_set() as files:
    for final in (out / "metrics.json", out / "2022-08-11" / "stops.parquet"):
        files.path_for(final).write_bytes(b"half a file")
    print("writing", flush=True)
    sys.stdin.read()
"""


def test_the_next_run_removes_the_temporaries_a_killed_run_left_and_nothing_else(
    example_csv: Path, tmp_path: Path
):
    """The temporaries go because the killed run's lock lists them, not because of their
    names: a user's file named like one, in the folder or below it, stays."""
    import subprocess
    import sys

    out = tmp_path / "week"
    kept = [  # not marops's name, or named so by a user: no run recorded them
        out / ".metrics.json.k1l2e3d4.tmp",
        out / ".thesis-draft.tmp",
        out / ".metrics.json.marops-k1l2e3d4.tmp",
        out / "2022-08-11" / ".stops.parquet.marops-x9y8z7w6.tmp",
        out / "keep" / "deeper" / ".stops.parquet.marops-abcdefgh.tmp",
    ]
    for p in kept:
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(b"a user's file")
    killed = subprocess.Popen(
        [sys.executable, "-c", KILLED, str(out)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert killed.stdout is not None and killed.stdout.readline() == "writing\n"
    killed.kill()
    killed.wait()
    stale = [p for p in out.rglob("*.tmp") if p not in kept]
    assert len(stale) == 2 and (out / ".marops.lock").exists()
    args = ["replay-day", *SQUARE, str(example_csv), "--dates", "0811..0812", "--method", "stay"]
    res = CliRunner().invoke(app, [*args, "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert not any(p.exists() for p in stale)
    assert all(p.read_bytes() == b"a user's file" for p in kept)
    assert not (out / ".marops.lock").exists()


def test_sigterm_exits_143_with_one_line_and_leaves_outputs_complete_or_absent(
    example_csv: Path, tmp_path: Path, stop_marops
):
    out = tmp_path / "week"
    args = ["replay-day", *SQUARE, str(example_csv), "--dates", "0801..0812"]
    args += ["--method", "greedy"]
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
