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


def _fails(args: list[str], out: Path, *needles: str) -> str:
    res = runner.invoke(app, args)
    assert res.exit_code == 2, res.output
    err = res.stderr.strip()
    assert len(err.splitlines()) == 1, err
    assert "Traceback" not in res.output
    for n in needles:
        assert n in err, (n, err)
    assert not out.exists(), "something was written"
    return err


def test_bad_method_name(example_csv: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--methods", "greedy,mapo", "--out", str(out)]
    _fails(args, out, "unknown method 'mapo'", "ops-global")


def test_learned_method_without_actor_names_what_is_missing(
    example_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("MAROPS_POLICY", str(tmp_path / "missing.pt"))
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--methods", "marops,greedy", "--out", str(out)]
    _fails(args, out, "missing", "--policy")


def test_mappo_without_actor_names_its_flag(example_csv: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--methods", "mappo", "--out", str(out)]
    args += ["--mappo-policy", str(tmp_path / "none.pt")]
    _fails(args, out, "none.pt", "--mappo-policy")


def test_dates_and_split_exclusive(example_csv: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--dates", "0811", "--split", "test", "--out", str(out)]
    _fails(args, out, "--dates", "--split")


def test_bad_sweep_value(example_csv: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--methods", "greedy", "--alpha", "0.5,2"]
    _fails([*args, "--out", str(out)], out, "alpha")
