"""A family of the bad-input contract: a file marops did not write where a command
writes, whatever its name. Each command stops before any work: exit 2, one line naming
the file, the file unchanged, nothing written (docs/outputs.md)."""

from __future__ import annotations

from pathlib import Path

import pytest

E = "0811"
# replay-day's files of one study square lie in --out itself (a city's, in a folder per hub).
SQUARE = ["--area", "square"]

CASES = {
    "synth data.csv": ("data.csv", ["synth", "--days", "1", "--out", "{out}/data.csv"]),
    "segment depots.png": (
        "depots.png",
        ["segment", "{data}", "--dates", E, "--plot", "--out", "{out}/depots.json"],
    ),
    "replay-day routes.png": (
        "routes.png",
        ["replay-day", *SQUARE, "{data}", "--date", E, "--method", "stay", "--plot"]
        + ["--out", "{out}"],
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
    # Refused before the replays run (it was refused after them, the jobs written).
    "evaluate unfairness.png": (
        "unfairness.png",
        ["evaluate", "{data}", "--methods", "stay", "--dates", E, "--out", "{out}"],
    ),
    "evaluate alpha.png": (
        "alpha.png",
        ["evaluate", "{data}", "--methods", "stay", "--alpha", "0.3,0.6", "--dates", E]
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


NOT_ASKED = {
    "replay-day routes.png": (
        "routes.png",
        ["replay-day", *SQUARE, "{data}", "--date", E, "--method", "stay", "--out", "{out}"],
    ),
    "replay-day --dates stops.parquet": (
        "stops.parquet",  # the days' files go to a folder each, below it
        ["replay-day", *SQUARE, "{data}", "--dates", "0811..0812", "--method", "stay"]
        + ["--out", "{out}"],
    ),
    "segment depots.png": ("depots.png", ["segment", "{data}", "--out", "{out}/depots.json"]),
    "segment depots.geojson": (
        "depots.geojson",
        ["segment", "{data}", "--out", "{out}/depots.json"],
    ),
    "plan-window routes.geojson": (
        "routes.geojson",
        ["plan-window", "{data}", "--depots", "{depots}", "--date", E, "--window", "1"]
        + ["--out", "{out}"],
    ),
    "evaluate paired.csv": (
        "paired.csv",
        ["evaluate", "{data}", "--methods", "stay", "--dates", E, "--out", "{out}"],
    ),
    "evaluate --no-plot unfairness.png": (
        "unfairness.png",
        ["evaluate", "{data}", "--methods", "stay", "--dates", E, "--no-plot", "--out", "{out}"],
    ),
}


@pytest.mark.parametrize("case", NOT_ASKED)
def test_a_file_no_option_asks_for_is_no_obstacle(
    case: str, example_csv: Path, tmp_path: Path
) -> None:
    """A file by the name of an output the options do not ask for is left alone and
    stops nothing (segment refused a depots.png without --plot, plan-window a
    routes.geojson without --geojson, evaluate a paired.csv without --against, and
    replay-day --dates a stops.parquet above the days' folders, each asking for
    --force)."""
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    name, args = NOT_ASKED[case]
    out = tmp_path / "out"
    out.mkdir()
    (out / name).write_bytes(b"a user's own file")
    depots = tmp_path / "depots.json"
    if "{depots}" in args:
        res = CliRunner().invoke(app, ["segment", str(example_csv), "--out", str(depots)])
        assert res.exit_code == 0, res.output
    argv = [a.format(out=out, data=example_csv, depots=depots) for a in args]
    res = CliRunner().invoke(app, argv)
    assert res.exit_code == 0, res.output
    assert (out / name).read_bytes() == b"a user's own file"


@pytest.mark.parametrize("hubs", [[], ["--hubs", "auto"]], ids=["depots", "hubs"])
def test_segment_out_the_current_folder_says_it_is_a_folder(
    example_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fails_cleanly, hubs
) -> None:
    """``--out .`` for a command that writes a file: the line said ``got`` and nothing
    (a folder's name is empty); now it names the folder and what --out takes."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "notes.txt").write_text("a user's notes")
    args = ["segment", str(example_csv), *hubs, "--out", "."]
    line = fails_cleanly(args, tmp_path, ".json; this is a folder")
    assert line.startswith("marops: error: .: --out names the "), line
    assert (tmp_path / "notes.txt").read_text() == "a user's notes"


@pytest.mark.parametrize("force", [[], ["--force"]], ids=["plain", "force"])
def test_a_foreign_file_by_the_journal_s_name_is_never_rewritten(
    example_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fails_cleanly, force
) -> None:
    """A folder holding a ``.marops-files.json`` that is no marops journal: a file the
    journal must list (replay-day's routes.png here) is refused before any work, naming
    it, and the file stays as it was; --force replaces it."""
    from typer.testing import CliRunner

    from marops_cli.cli.app import app
    from marops_cli.io.ownership import new_run

    monkeypatch.chdir(tmp_path)
    journal = tmp_path / ".marops-files.json"
    journal.write_text("a user's own file\n")
    args = ["replay-day", *SQUARE, str(example_csv), "--date", E, "--method", "stay", "--plot"]
    args += ["--out", ".", *force]
    if not force:
        fails_cleanly(args, tmp_path, ".marops-files.json: ", "not the journal", "--out")
        assert journal.read_text() == "a user's own file\n"
        return
    try:
        res = CliRunner().invoke(app, args)
    finally:
        new_run()  # --force stays set in this process after the command: not for the next test
    assert res.exit_code == 0, res.output
    assert '"routes.png"' in journal.read_text()


def test_synth_force_replaces_a_foreign_file(tmp_path: Path) -> None:
    """The refusal says "pass --force", and synth takes it: the file becomes marops'."""
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    foreign = tmp_path / "data.csv"
    foreign.write_bytes(b"someone's own file")
    args = ["synth", "--days", "1", "--out", str(foreign)]
    refused = CliRunner().invoke(app, args)
    assert refused.exit_code == 2 and "pass --force" in refused.output
    res = CliRunner().invoke(app, [*args, "--force"])
    assert res.exit_code == 0, res.output
    assert foreign.read_bytes().startswith(b"order_id,")
