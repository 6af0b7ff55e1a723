"""A family of the bad-input contract: a file marops did not write where a command
writes, whatever its name. Each command stops before any work: exit 2, one line naming
the file, the file unchanged, nothing written (docs/outputs.md)."""

from __future__ import annotations

from pathlib import Path

import pytest

E = "0811"

CASES = {
    "synth data.csv": ("data.csv", ["synth", "--days", "1", "--out", "{out}/data.csv"]),
    "segment depots.png": (
        "depots.png",
        ["segment", "{data}", "--dates", E, "--plot", "--out", "{out}/depots.json"],
    ),
    "replay-day routes.png": (
        "routes.png",
        ["replay-day", "{data}", "--date", E, "--method", "stay", "--plot", "--out", "{out}"],
    ),
    "evaluate summary.csv": (
        "summary.csv",
        ["evaluate", "{data}", "--methods", "stay", "--dates", E, "--out", "{out}"],
    ),
    "evaluate summary.md": (
        "summary.md",
        ["evaluate", "{data}", "--methods", "stay", "--dates", E, "--out", "{out}"],
    ),
    "evaluate paired.csv": (
        "paired.csv",
        ["evaluate", "{data}", "--methods", "stay,greedy", "--against", "stay", "--dates", E]
        + ["--out", "{out}"],
    ),
    "train a.pt": ("a.pt", ["train", "{data}", "--episodes", "1", "--out", "{out}/a.pt"]),
    "train a.ckpt": ("a.ckpt", ["train", "{data}", "--episodes", "1", "--out", "{out}/a.pt"]),
    "train a.curve.png": (
        "a.curve.png",
        ["train", "{data}", "--episodes", "1", "--out", "{out}/a.pt"],
    ),
}


@pytest.mark.parametrize("case", CASES)
def test_a_foreign_file_where_a_command_writes(
    case: str, example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    name, args = CASES[case]
    out = tmp_path / "out"
    out.mkdir()
    foreign = out / name
    foreign.write_bytes(b"someone's own file")
    argv = [a.format(out=out, data=example_csv) for a in args]
    fails_cleanly(argv, out, str(foreign), "not written by marops")
    assert foreign.read_bytes() == b"someone's own file"


def test_a_file_no_option_asks_for_is_no_obstacle(example_csv: Path, tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    out = tmp_path / "out"
    out.mkdir()
    (out / "routes.png").write_bytes(b"a user's map")  # replay-day without --plot
    args = ["replay-day", str(example_csv), "--date", E, "--method", "stay", "--out", str(out)]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    assert (out / "routes.png").read_bytes() == b"a user's map"
