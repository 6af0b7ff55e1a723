"""Counts of processes and episodes past what any machine runs are refused before any
work: a mistyped --workers 10000 would start that many processes (docs/outputs.md)."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.mark.parametrize(
    ("command", "needle"),
    [
        (["evaluate", "--dates", "0811", "--methods", "stay", "--workers", "10000"], "1 to 256"),
        (["replay-day", "--dates", "0811..0812", "--method", "stay", "--workers", "999"], "256"),
        (["train", "--workers", "1000"], "workers ≤ 256"),
        (["train", "--episodes", "100000000"], "episodes ≤ 1e7"),
    ],
    ids=["evaluate-workers", "replay-workers", "train-workers", "train-episodes"],
)
def test_counts_past_any_machine_are_one_line(
    example_csv: Path, tmp_path: Path, fails_cleanly, command: list[str], needle: str
) -> None:
    out = tmp_path / ("a.pt" if command[0] == "train" else "out")
    args = [command[0], str(example_csv), *command[1:], "--out", str(out)]
    fails_cleanly(args, tmp_path, needle)


@pytest.mark.parametrize("command", ["evaluate", "replay-day"])
def test_no_workers_is_the_same_line_as_too_many(
    example_csv: Path, tmp_path: Path, fails_cleanly, command: str
) -> None:
    """--workers 0 says the range, as --workers 999 does, and --help gives that range
    alone (it read "[default: 2; x>=1]" beside "1 to 256")."""
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    args = [command, str(example_csv), "--dates", "0811", "--workers", "0"]
    line = fails_cleanly([*args, "--out", str(tmp_path / "out")], tmp_path)
    assert line == "marops: error: --workers expects 1 to 256, got 0", line
    text = " ".join(CliRunner().invoke(app, [command, "--help"]).output.split())
    assert "x>=1" not in text and "--workers" in text and "1 to 256" in text
