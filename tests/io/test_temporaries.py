"""Temporaries: a run removes only marops's own, in the folders it writes (docs/outputs.md)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import pytest

from marops_cli.io import atomic, output_set

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


def _handled(signum: int) -> None:
    """Python runs ``signum``'s handler here, as it does in the main thread whichever of
    the process's threads (Arrow's, OpenMP's, which a run has) the signal reached."""
    handler = signal.getsignal(signum)
    assert callable(handler)
    handler(signum, None)


def test_ctrl_c_during_the_renames_waits_for_the_whole_set(tmp_path: Path, monkeypatch) -> None:
    """A day's files are renamed into place together: Ctrl-C then waits for the last.
    Blocking the signal in the main thread did not hold it back once the run had other
    threads (they took it, and Python raised it in the main thread all the same): a
    stopped run kept a day's stops without its routes."""
    rename = os.replace

    def replace(src: Any, dst: Any) -> None:
        rename(src, dst)
        _handled(signal.SIGINT)

    with pytest.raises(KeyboardInterrupt), output_set() as files:  # noqa: PT012
        files.write_bytes(tmp_path / "stops.parquet", b"stops")
        files.write_bytes(tmp_path / "routes.parquet", b"routes")
        monkeypatch.setattr(os, "replace", replace)
    monkeypatch.undo()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["routes.parquet", "stops.parquet"]


def test_ctrl_c_as_a_temporary_is_made_leaves_none(tmp_path: Path, monkeypatch) -> None:
    """Ctrl-C between making a temporary and listing it in its set left it behind
    (``.report.html.marops-XXXXXXXX.tmp`` of a stopped ``marops report``): the set
    removes only those it lists."""
    make = atomic.temporary

    def temporary(folder: Path, name: str) -> Path:
        tmp = make(folder, name)
        _handled(signal.SIGINT)
        return tmp

    monkeypatch.setattr(atomic, "temporary", temporary)
    with pytest.raises(KeyboardInterrupt), output_set() as files:
        files.write_bytes(tmp_path / "report.html", b"<html>")
    assert list(tmp_path.iterdir()) == []


def test_sigterm_as_an_output_s_folder_is_checked_leaves_no_probe(
    tmp_path: Path, monkeypatch
) -> None:
    """The check that an output's folder takes files makes and removes a probe: SIGTERM
    in between left the probe."""
    from marops_cli.io.atomic import Terminated
    from marops_cli.io.ownership import check_outputs

    def terminate(signum: int, frame: object) -> None:
        raise Terminated()

    make = tempfile.mkstemp

    def mkstemp(*args: Any, **kwargs: Any) -> tuple[int, str]:
        made = make(*args, **kwargs)
        _handled(signal.SIGTERM)
        return made

    old = signal.signal(signal.SIGTERM, terminate)
    try:
        monkeypatch.setattr(tempfile, "mkstemp", mkstemp)
        with pytest.raises(Terminated):
            check_outputs([tmp_path / "routes.parquet"])
    finally:
        signal.signal(signal.SIGTERM, old)
    assert list(tmp_path.iterdir()) == []
