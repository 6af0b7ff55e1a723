"""Temporaries: a run removes only marops's own, in the folders it writes (docs/outputs.md)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from marops_cli.io import output_set

MAIN = "from marops_cli.cli.app import main; main()"


def test_a_run_leaves_a_user_s_hidden_tmp_files_alone(example_csv: Path, tmp_path: Path) -> None:
    sweep = tmp_path / "sweep"
    mine = [
        sweep / ".thesis-draft.tmp",
        sweep / "keep" / ".notes.tmp",
        sweep / "keep" / "deeper" / ".thesis-draft.tmp",
    ]
    for p in mine:
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text("a chapter")
    args = ["replay-day", "--area", "square", example_csv, "--date", "0811", "--method", "stay"]
    args += ["--out", sweep]
    res = subprocess.run(
        [sys.executable, "-c", MAIN, *map(str, args)], capture_output=True, text=True
    )
    assert res.returncode == 0, res.stderr
    assert (sweep / "routes.parquet").exists()
    assert all(p.read_text() == "a chapter" for p in mine)


def test_temporaries_carry_marops_s_name(tmp_path: Path) -> None:
    with output_set() as files:
        tmp = files.path_for(tmp_path / "routes.parquet")
        assert re.fullmatch(r"\.routes\.parquet\.marops-[a-z0-9_]{8}\.tmp", tmp.name)
        tmp.write_bytes(b"x")
    assert [p.name for p in tmp_path.iterdir()] == ["routes.parquet"]
