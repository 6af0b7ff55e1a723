"""Bad input: one line naming file/row/column, exit code 2, nothing written."""

from __future__ import annotations

import contextlib
import json
from pathlib import Path

import pytest

HEADER = (
    "order_id,region_id,city,courier_id,lng,lat,aoi_id,aoi_type,accept_time,accept_gps_time,"
    "accept_gps_lng,accept_gps_lat,delivery_time,delivery_gps_time,delivery_gps_lng,"
    "delivery_gps_lat,ds"
)


def _row(
    oid: int,
    lng: str = "121.47",
    lat: str = "31.23",
    acc: str = "08-20 08:00:00",
    dlv: str = "08-20 10:00:00",
    ds: str = "820",
) -> str:
    return f"{oid},1,Shanghai,7,{lng},{lat},5,1,{acc},,,,{dlv},,,,{ds}"


def _write(tmp_path: Path, lines: list[str], name: str = "lade.csv") -> Path:
    p = tmp_path / name
    p.write_text("\n".join(lines) + "\n")
    return p


def test_missing_column(tmp_path: Path, fails_cleanly) -> None:
    data = _write(tmp_path, [HEADER.replace(",lat,", ",latitude,"), _row(1)])
    fails_cleanly(
        ["segment", str(data), "--n-depots", "1", "--out", str(tmp_path / "d.json")],
        tmp_path,
        "lade.csv",
        "row 1",
        "'lat'",
    )


def test_unparseable_time_names_row_and_column(tmp_path: Path, fails_cleanly) -> None:
    data = _write(tmp_path, [HEADER, _row(1), _row(2, dlv="08-20 25:99:00"), _row(3)])
    fails_cleanly(
        ["segment", str(data), "--n-depots", "1", "--out", str(tmp_path / "d.json")],
        tmp_path,
        "lade.csv",
        "row 3",
        "delivery_time",
    )


def test_not_a_lade_file(tmp_path: Path, fails_cleanly) -> None:
    data = _write(tmp_path, ["hello,world", "1,2"], "notes.csv")
    fails_cleanly(["segment", str(data), "--out", str(tmp_path / "d.json")], tmp_path, "notes.csv")


def test_missing_file(tmp_path: Path, fails_cleanly) -> None:
    fails_cleanly(
        ["segment", str(tmp_path / "nope.csv"), "--out", str(tmp_path / "d.json")],
        tmp_path,
        "nope.csv",
    )


def test_date_not_in_file(example_csv: Path, tmp_path: Path, fails_cleanly) -> None:
    fails_cleanly(
        [
            "replay-day",
            str(example_csv),
            "--date",
            "0911",
            "--method",
            "greedy",
            "--out",
            str(tmp_path / "out"),
        ],
        tmp_path,
        "2022-09-11",
        "shanghai_synth.csv",
    )


@pytest.mark.parametrize(
    ("args", "flag"),
    [
        (["segment", "--dates", ""], "--dates"),  # was every day, the replay days too
        (["segment", "--hubs", "auto", "--dates", ""], "--dates"),
        (["replay-day", "--date", ""], "--date"),  # was blamed on --dates
        (["train", "--dates", ""], "--dates"),  # was every day
    ],
    ids=["segment", "segment-hubs", "replay-day", "train"],
)
def test_an_empty_list_of_days_is_refused_naming_its_option(
    example_csv: Path, tmp_path: Path, fails_cleanly, args: list[str], flag: str
) -> None:
    """An unset shell variable (``--dates "$HIST"``) is bad usage naming the option given,
    never a default."""
    out = tmp_path / {"replay-day": "out", "train": "a.pt"}.get(args[0], "d.json")
    line = fails_cleanly([args[0], str(example_csv), *args[1:], "--out", str(out)], tmp_path)
    assert f"invalid option {flag}:" in line and "got ''" in line


def test_empty_study_area(example_csv: Path, tmp_path: Path, fails_cleanly) -> None:
    fails_cleanly(
        ["segment", str(example_csv), "--center", "100.0,10.0", "--out", str(tmp_path / "d.json")],
        tmp_path,
        "shanghai_synth.csv",
        "no requests",
    )


def test_strict_turns_a_dropped_row_into_an_error(tmp_path: Path, fails_cleanly) -> None:
    rows = [HEADER] + [_row(i, lng=f"121.4{i}") for i in range(1, 6)] + [_row(9, lng="0", lat="0")]
    data = _write(tmp_path, rows)
    fails_cleanly(
        ["segment", str(data), "--n-depots", "1", "--strict", "--out", str(tmp_path / "d.json")],
        tmp_path,
        "lade.csv",
        "row 7",
    )


def test_bad_option_values(example_csv: Path, tmp_path: Path, fails_cleanly) -> None:
    fails_cleanly(
        [
            "replay-day",
            str(example_csv),
            "--date",
            "0811",
            "--alpha",
            "1.5",
            "--out",
            str(tmp_path / "o"),
        ],
        tmp_path,
        "alpha",
    )
    fails_cleanly(
        [
            "replay-day",
            str(example_csv),
            "--date",
            "0811",
            "--method",
            "fastest",
            "--out",
            str(tmp_path / "o"),
        ],
        tmp_path,
        "fastest",
    )
    fails_cleanly(
        ["segment", str(example_csv), "--center", "east", "--out", str(tmp_path / "d.json")],
        tmp_path,
        "--center",
    )


@pytest.mark.parametrize("content", ["{bad", '{"frame": {}}'])
def test_bad_depots_file(example_csv: Path, tmp_path: Path, content: str, fails_cleanly) -> None:
    dep = tmp_path / "depots.json"
    dep.write_text(content)
    fails_cleanly(
        [
            "plan-window",
            str(example_csv),
            "--depots",
            str(dep),
            "--date",
            "0811",
            "--window",
            "3",
            "--out",
            str(tmp_path / "w"),
        ],
        tmp_path,
        "depots.json",
    )


def test_bad_training_lists(example_csv: Path, tmp_path: Path, fails_cleanly) -> None:
    out = str(tmp_path / "a.pt")
    base = ["train", str(example_csv), "--episodes", "1", "--out", out]
    fails_cleanly([*base, "--drones", "8,x"], tmp_path, "--drones", "8,x")
    fails_cleanly([*base, "--n-depots", "0"], tmp_path, "--n-depots")
    fails_cleanly([*base, "--alpha-range", "low-high"], tmp_path, "--alpha-range")
    fails_cleanly([*base, "--alpha-range", "0.9-0.1"], tmp_path, "--alpha-range")
    es = ["train", str(example_csv), "--algorithm", "es", "--out", str(tmp_path / "a.safetensors")]
    fails_cleanly([*es, "--energy-slack", "-0.01"], tmp_path, "--energy-slack")
    fails_cleanly([*es, "--energy-slack", "2"], tmp_path, "--energy-slack")
    fails_cleanly([*es, "--energy-weight", "-1"], tmp_path, "--energy-weight")
    fails_cleanly([*es, "--loss-weight", "-0.5"], tmp_path, "--loss-weight")
    missing = str(tmp_path / "nope.csv")
    fails_cleanly(["train", str(example_csv), missing, "--out", out], tmp_path, "nope.csv")


# An input path that is a loop of symbolic links, for each option that reads a file: the
# data said "file not found" (it exists as a link), the others "Too many levels of
# symbolic links"; now each is one line naming the path and saying it is a loop.
LOOP_INPUTS = {
    "data": ["segment", "{loop}", "--out", "{out}/d.json"],
    "train data": ["train", "{loop}", "--episodes", "1", "--out", "{out}/a.pt"],
    "depots": ["replay-day", "{data}", "--date", "0811", "--depots", "{loop}", "--out", "{out}"],
    "config": ["replay-day", "{data}", "--date", "0811", "--config", "{loop}", "--out", "{out}"],
    "fleet": ["replay-day", "{data}", "--date", "0811", "--fleet", "{loop}", "--out", "{out}"],
    "policy": ["replay-day", "{data}", "--date", "0811", "--policy", "{loop}.pt"]
    + ["--out", "{out}"],
    "hubs": ["evaluate", "{data}", "--dates", "0811", "--hubs", "{loop}", "--out", "{out}"],
    "delivered": ["plan-window", "{data}", "--depots", "{depots}", "--date", "0811"]
    + ["--window", "5", "--delivered", "{loop}", "--out", "{out}"],
    "report folder": ["report", "{loop}"],
}


@pytest.mark.parametrize("name", sorted(LOOP_INPUTS))
def test_a_loop_of_symbolic_links_as_an_input(
    example_csv: Path, tmp_path: Path, fails_cleanly, name: str
) -> None:
    loops = tmp_path / "loops"
    loops.mkdir()
    for stem in ("loop", "loop.pt"):
        (loops / stem).symlink_to(loops / f"{stem}.2")
        (loops / f"{stem}.2").symlink_to(loops / stem)
    depots = tmp_path / "depots.json"
    seg = ["segment", str(example_csv), "--dates", "0801..0810", "--out", str(depots)]
    if name == "delivered":
        from typer.testing import CliRunner

        from marops_cli.cli.app import app

        assert CliRunner().invoke(app, seg).exit_code == 0
    values = {"loop": loops / "loop", "data": example_csv, "depots": depots, "out": tmp_path / "o"}
    args = [a.format(**values) for a in LOOP_INPUTS[name]]
    loop = str(loops / ("loop.pt" if name == "policy" else "loop"))
    line = fails_cleanly(args, tmp_path, f"marops: error: {loop}: is a loop of symbolic links")
    assert "Errno" not in line and "Too many levels" not in line


PLAN_WINDOW = ["plan-window", "{data}", "--depots", "{depots}", "--date", "0811", "--window", "5"]
TOO_LONG = {
    "plan-window --out": [*PLAN_WINDOW, "--out", "{long}"],
    "replay-day --out": ["replay-day", "{data}", "--date", "0811", "--out", "{long}"],
    "segment --out": ["segment", "{data}", "--out", "{long}/depots.json"],
}


def test_a_file_where_a_hub_s_folder_goes_is_refused_before_any_work(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """``OUT/hub-0`` a file in a city run (once ``File exists``, exit 1, after segmenting):
    refused naming it before any work, as a day's folder that is a file is."""
    out = tmp_path / "city"
    out.mkdir()
    (out / "hub-0").write_text("mine")
    (out / "hub-notes").write_text("mine")  # no hub's name: no obstacle
    args = ["replay-day", str(example_csv), "--date", "0811", "--area", "hubs"]
    fails_cleanly([*args, "--out", str(out)], tmp_path, f"{out / 'hub-0'} is a file")
    assert (out / "hub-0").read_text() == "mine"


@pytest.mark.parametrize("name", sorted(TOO_LONG))
def test_a_folder_name_too_long_is_one_line_naming_the_path(
    example_csv: Path, tmp_path: Path, fails_cleanly, name: str
) -> None:
    # A name in the path longer than the file system takes, under a folder that exists:
    # the path and the reason, not Python's "[Errno 36] ..." (exit 2: bad usage).
    depots = tmp_path / "depots.json"
    depots.write_text("{}")
    (tmp_path / "sub").mkdir()
    long = tmp_path / "sub" / ("x" * 300)
    values = {"data": str(example_csv), "depots": str(depots), "long": str(long)}
    args = [a.format(**values) for a in TOO_LONG[name]]
    line = fails_cleanly(args, tmp_path, f"marops: error: {long}", "File name too long")
    assert "Errno" not in line


EMPTY_PATH = {
    "plan-window --out": [*PLAN_WINDOW, "--out", ""],
    "plan-window --delivered": [*PLAN_WINDOW, "--out", "o", "--delivered", ""],
    "plan-window --config": [*PLAN_WINDOW, "--out", "o", "--config="],
    "replay-day --out": ["replay-day", "{data}", "--date", "0811", "--out", ""],
    "segment DATA": ["segment", "", "--out", "d.json"],
    "evaluate --out": ["evaluate", "{data}", "--dates", "0811", "--out", ""],
}


@pytest.mark.parametrize("name", sorted(EMPTY_PATH))
def test_an_empty_path_is_bad_usage_not_the_current_folder(
    example_csv: Path, tmp_path: Path, name: str
) -> None:
    # Path("") is the current folder: `--out "$UNSET"` would write the run there.
    import os
    import subprocess
    import sys

    depots = tmp_path / "depots.json"
    depots.write_text("{}")
    args = [a.format(data=example_csv, depots=depots) for a in EMPTY_PATH[name]]
    main = "from marops_cli.cli.app import main; main()"
    root = str(Path(__file__).resolve().parents[2])  # this marops, run from tmp_path
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")])}
    res = subprocess.run(
        [sys.executable, "-c", main, *args], capture_output=True, text=True, cwd=tmp_path, env=env
    )
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    option = name.split()[1]
    assert f"'{option}'" in lines[0] and "expected a path, got an empty string" in lines[0]
    assert [p.name for p in tmp_path.iterdir()] == ["depots.json"]


def test_sigterm_inside_a_library_import_ends_as_terminated_not_a_traceback(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """SIGTERM landing inside pandas's lazy import leaves the module half made; the next
    use then fails with an AttributeError, which once printed a traceback."""
    import typer

    from marops_cli.cli import app as app_module
    from marops_cli.cli.common import guarded
    from marops_cli.io.atomic import TERM_RECEIVED, Terminated

    @guarded
    def evaluate_command() -> None:
        with contextlib.suppress(Terminated):  # swallowed by the extension's import
            app_module._terminate(15, None)  # the signal, inside the import
        raise AttributeError("partially initialized module 'pandas' has no attribute 'x'")

    try:
        with pytest.raises(typer.Exit) as stop:
            evaluate_command()
    finally:
        TERM_RECEIVED.clear()
    assert stop.value.exit_code == 143
    assert capsys.readouterr().err == "marops: terminated\n"


def test_requests_scattered_over_the_world_place_the_area_on_the_median_one(
    tmp_path: Path,
) -> None:
    """Requests thousands of km apart, one at the median position: the study area is the
    square around that one (the only square holding any), so segment places a depot on it.
    Before, the square had the request on its corner and held none: the run failed."""
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    # Row 20 falls on (0, 0), a bad fix that is dropped.
    rows = [_row(i, lng=f"{-170 + 8.5 * i:.3f}", lat=f"{-60 + 3 * i:.3f}") for i in range(40)]
    data = _write(tmp_path, [HEADER, *rows])
    out = tmp_path / "d.json"
    res = CliRunner().invoke(app, ["segment", str(data), "--n-depots", "1", "--out", str(out)])
    assert res.exit_code == 0, res.output
    doc = json.loads(out.read_text())
    assert doc["frame"]["center_lng"] == pytest.approx(-8.5, abs=0.01)
    assert doc["frame"]["center_lat"] == pytest.approx(-3.0, abs=0.01)
    assert doc["depots"][0]["n_history"] == 1


@pytest.mark.parametrize("spec", ["torchscript:", "torchscript:.", "torchscript:/"])
def test_a_torchscript_policy_naming_no_file_is_one_line(
    example_csv: Path, tmp_path: Path, spec: str, fails_cleanly
) -> None:
    """``--policy torchscript:`` with no file name (empty, ``.``, ``/``) is refused naming
    the option, not a ValueError traceback from the actor's file names."""
    args = ["replay-day", str(example_csv), "--date", "0811", "--policy", spec]
    fails_cleanly([*args, "--out", str(tmp_path / "o")], tmp_path, "--policy", spec)


@pytest.mark.parametrize("env", [".", "/"])
def test_marops_policy_naming_a_folder_without_a_name_is_one_line(
    example_csv: Path, tmp_path: Path, env: str, fails_cleanly, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``MAROPS_POLICY=.`` (or ``/``) is refused naming the variable, not a ValueError
    traceback from the actor's file names."""
    monkeypatch.setenv("MAROPS_POLICY", env)
    args = ["replay-day", str(example_csv), "--date", "0811", "--out", str(tmp_path / "o")]
    fails_cleanly(args, tmp_path, "MAROPS_POLICY", repr(env))


@pytest.mark.parametrize("flag", ["--policy", "--mappo-policy"])
def test_an_evaluate_actor_naming_no_file_is_one_line(
    example_csv: Path, tmp_path: Path, flag: str, fails_cleanly
) -> None:
    """evaluate's ``--policy .`` or ``--mappo-policy /`` is refused naming the option,
    not a ValueError traceback from the actor's file names."""
    args = ["evaluate", str(example_csv), "--dates", "0811", "--methods", "stay"]
    for path in (".", "/"):
        out = ["--out", str(tmp_path / "o"), flag, path]
        fails_cleanly([*args, *out], tmp_path, flag, repr(path))


@pytest.mark.parametrize("cell", ["", "  "])
def test_an_empty_weight_cell_is_called_empty(tmp_path: Path, cell: str, fails_cleanly) -> None:
    """An empty weight_kg cell among weights is named as an empty cell, where the line
    read 'got None' (or the blanks' repr)."""
    rows = [f"{_row(1)},0.5", f"{_row(2)},{cell}"]
    data = _write(tmp_path, [HEADER + ",weight_kg", *rows])
    args = ["segment", str(data), "--n-depots", "1", "--out", str(tmp_path / "d.json")]
    err = fails_cleanly(args, tmp_path, "row 3, column 'weight_kg'", "got an empty cell")
    assert "None" not in err
