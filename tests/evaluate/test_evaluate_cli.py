"""``marops evaluate`` usage: help, and one-line errors (exit 2) that write nothing."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app

runner = CliRunner()


def test_help() -> None:
    res = runner.invoke(app, ["evaluate", "--help"])
    assert res.exit_code == 0
    for flag in ("--methods", "--split", "--repeats", "--drones", "--alpha", "--workers"):
        assert flag in res.output


def test_bad_method_name(example_csv: Path, tmp_path: Path, fails_cleanly) -> None:
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--methods", "greedy,mapo", "--out", str(out)]
    fails_cleanly(args, tmp_path, "unknown method 'mapo'", "ops-global")


def test_learned_method_without_actor_names_what_is_missing(
    example_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fails_cleanly
) -> None:
    monkeypatch.setenv("MAROPS_POLICY", str(tmp_path / "missing.pt"))
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--methods", "marops,greedy", "--out", str(out)]
    fails_cleanly(args, tmp_path, "missing", "--policy")


def test_mappo_without_actor_names_its_flag(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--methods", "mappo", "--out", str(out)]
    args += ["--mappo-policy", str(tmp_path / "none.pt")]
    fails_cleanly(args, tmp_path, "none.pt", "--mappo-policy")


def test_dates_and_split_exclusive(example_csv: Path, tmp_path: Path, fails_cleanly) -> None:
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--dates", "0811", "--split", "test", "--out", str(out)]
    fails_cleanly(args, tmp_path, "--dates", "--split")


def test_bad_sweep_value(example_csv: Path, tmp_path: Path, fails_cleanly) -> None:
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--methods", "greedy", "--alpha", "0.5,2"]
    fails_cleanly([*args, "--out", str(out)], tmp_path, "alpha")
