"""An interrupted evaluation keeps what finished and resumes from it; --out is checked first."""

from __future__ import annotations

import datetime as dt
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.config import PlannerConfig
from marops_cli.evaluate import expand_settings, prepare
from marops_cli.evaluate.runner import Journal, run, run_identity

DAYS = [dt.date(2022, 8, 11), dt.date(2022, 8, 12)]


@pytest.fixture(scope="module")
def prep(example_csv: Path):
    cfg = PlannerConfig()
    return prepare(example_csv, cfg, ["stay", "greedy"], expand_settings(cfg), days=DAYS)


def _timeless(rows: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k not in ("runtime_s", "solver")} for r in rows]


def test_interrupted_run_resumes_to_the_same_rows(prep, tmp_path: Path) -> None:
    full = run(prep, workers=1)
    journal = Journal(tmp_path / "j.jsonl", run_identity(prep))

    def stop_after_two(done: int, total: int, job) -> None:
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run(prep, workers=1, on_result=stop_after_two, journal=journal)
    lines = journal.path.read_text().splitlines()
    assert len(lines) == 1 + 2  # the identity, then the two finished jobs
    ran: list[int] = []
    again = Journal(journal.path, run_identity(prep))
    rows = run(prep, 1, lambda d, t, job: ran.append(job.index), again)
    assert sorted(again.done) == [0, 1] and sorted(ran) == [2, 3]  # only the rest ran
    assert _timeless(rows) == _timeless(full)


def test_a_journal_of_other_settings_is_refused(prep, tmp_path: Path) -> None:
    path = tmp_path / "j.jsonl"
    path.write_text(json.dumps({"identity": "another run"}) + "\n")
    with pytest.raises(Exception, match="other settings"):
        run(prep, 1, None, Journal(path, run_identity(prep)))


def test_out_that_is_a_file_fails_before_any_work(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    out = tmp_path / "out"
    out.write_text("not a folder")
    args = ["evaluate", str(example_csv), "--methods", "stay", "--out", str(out)]
    fails_cleanly(args, tmp_path, "--out must be a folder")


def test_ctrl_c_exits_130_keeps_finished_jobs_and_prints_no_traceback(
    example_csv: Path, tmp_path: Path
) -> None:
    out = tmp_path / "ev"
    args = ["evaluate", str(example_csv), "--methods", "stay,greedy,ops-random,myopic"]
    args += ["--dates", "0811..0812", "--workers", "2", "--no-plot", "--out", str(out)]
    code = "from marops_cli.cli.app import main; main()"
    proc = subprocess.Popen(
        [sys.executable, "-c", code, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, like a terminal's
    )
    journal = out / "evaluate.partial.jsonl"
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and proc.poll() is None:
        if journal.is_file() and len(journal.read_text().splitlines()) >= 2:
            break
        time.sleep(0.05)
    assert proc.poll() is None, "finished before it could be interrupted"
    os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C: the whole group, workers included
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    assert "run the same command again to resume" in err
    kept = len(journal.read_text().splitlines()) - 1
    assert kept >= 1 and not (out / "results.parquet").exists()
    # the same command resumes and finishes; the journal goes when the outputs are written
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    assert f"resumed: {kept} of 8 replays" in res.output
    assert (out / "results.parquet").is_file() and not journal.exists()
