"""A first run without rough edges: errors that name the flag and say how to write it,
--debug after the command, the data from standard input, outputs checked up front."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.cli.common import STATE
from marops_cli.errors import InputError

runner = CliRunner()


def test_debug_after_the_command_shows_the_traceback(example_csv: Path, tmp_path: Path) -> None:
    (tmp_path / "afile").write_text("x")
    args = ["segment", str(example_csv), "--out", str(tmp_path / "afile" / "d.json")]
    assert runner.invoke(app, args).exit_code == 2  # without --debug: one line
    for debug in ([*args, "--debug"], ["--debug", *args]):
        res = runner.invoke(app, debug)
        assert isinstance(res.exception, InputError), res.output  # raised, not one line
    STATE["debug"] = False


def test_debug_as_a_value_after_double_dash_is_left_alone() -> None:
    from marops_cli.cli.usage import hoist_debug

    assert hoist_debug(["replay-day", "x.csv", "--debug"]) == ["--debug", "replay-day", "x.csv"]
    assert hoist_debug(["replay-day", "--", "--debug"]) == ["replay-day", "--", "--debug"]


@pytest.mark.parametrize(
    "args",
    [
        ["replay-day", "--date", "0811", "--alpha", "1.5"],
        ["plan-window", "--depots", "DEPOTS", "--date", "0811", "--window", "5", "--alpha", "1.5"],
    ],
    ids=["replay-day", "plan-window"],
)
def test_a_bad_value_names_its_flag(
    example_csv: Path, tmp_path: Path, fails_cleanly, args: list[str]
) -> None:
    depots = tmp_path / "in" / "depots.json"
    depots.parent.mkdir()
    depots.write_text("{}")
    args = [a if a != "DEPOTS" else str(depots) for a in args]
    line = fails_cleanly(
        [args[0], str(example_csv), *args[1:], "--out", str(tmp_path / "out")], tmp_path, "--alpha"
    )
    assert "plan.alpha" not in line and "1.5" in line


def test_a_value_click_refuses_is_quoted_with_where_it_came_from(
    example_csv: Path, tmp_path: Path
) -> None:
    """``--drones abc``: the line quotes the value and names the environment variable
    only when the value came from it."""
    import os
    import subprocess
    import sys

    main = "from marops_cli.cli.app import main; main()"
    base = [sys.executable, "-c", main, "replay-day", str(example_csv), "--date", "0811"]
    env = {k: v for k, v in os.environ.items() if k != "MAROPS_DRONES"}
    for i, (extra, environ, needles, absent) in enumerate(
        (
            (["--drones", "abc"], env, ("'--drones'", "got 'abc'"), "env var"),
            (["--drones=x2"], {**env, "MAROPS_DRONES": "7"}, ("got 'x2'",), "env var"),
            ([], {**env, "MAROPS_DRONES": "abc"}, ("env var: 'MAROPS_DRONES'", "got 'abc'"), "x2"),
        )
    ):
        out = tmp_path / f"out{i}"
        res = subprocess.run(
            [*base, *extra, "--out", str(out)], capture_output=True, text=True, env=environ
        )
        (line,) = res.stderr.splitlines()
        assert res.returncode == 2 and not out.exists()
        assert all(n in line for n in needles) and absent not in line, line


def test_a_bad_value_names_a_variable_only_when_click_read_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Where a value came from is click's own record of it: a variable set but empty
    (click passes over it) is not where a bad value came from, nor quoted as it."""
    import sys

    import click

    from marops_cli.cli.app import _named_source

    @click.command()
    @click.option("--n", type=int, default="zz", envvar="MAROPS_TEST_N")
    def command(n: int) -> None:
        """A bad default: the value came from neither the line nor the variable."""

    monkeypatch.setattr(sys, "argv", ["marops"])
    for environ, ending in (("", "'zz' is not a valid integer."), ("yy", ", got 'yy'")):
        monkeypatch.setenv("MAROPS_TEST_N", environ)
        with pytest.raises(click.BadParameter) as err:
            command.main([], standalone_mode=False)
        text = " ".join(err.value.format_message().split())
        assert _named_source(text, err.value.param, err.value.ctx).endswith(ending)


def test_a_value_out_of_range_names_the_environment_variable_it_came_from(
    example_csv: Path, tmp_path: Path
) -> None:
    """``MAROPS_DRONES=-1``: the value click takes but the planner refuses was reported as
    ``--drones``, a flag never given; it names the variable, as click's own errors do, and
    a flag given on the line is named alone."""
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    base = ["replay-day", str(example_csv), "--date", "0811", "--area", "square"]
    for i, (extra, environ, needles, absent) in enumerate(
        (
            ([], {"MAROPS_DRONES": "-1"}, ("--drones (env var: 'MAROPS_DRONES')", "got -1"), ""),
            (["--drones", "-1"], {"MAROPS_DRONES": "5"}, ("--drones: ", "got -1"), "env var"),
            (["--drones", "-1"], {"MAROPS_DRONES": None}, ("--drones: ", "got -1"), "env var"),
        )
    ):
        out = tmp_path / f"out{i}"
        res = CliRunner().invoke(app, [*base, *extra, "--out", str(out)], env=environ)
        (line,) = res.stderr.splitlines()
        assert res.exit_code == 2 and not out.exists()
        assert all(n in line for n in needles) and (not absent or absent not in line), line


def test_a_range_written_with_a_dash_gets_a_hint(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    for cmd, out in (("segment", "d.json"), ("replay-day", "out")):
        args = [cmd, str(example_csv), "--dates", "0801-0810", "--out", str(tmp_path / out)]
        fails_cleanly(args, tmp_path, "'0801-0810'", "0801..0810")


def test_more_actions_than_depots_is_an_error(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    args = ["segment", str(example_csv), "--n-depots", "2", "--actions", "4"]
    fails_cleanly([*args, "--out", str(tmp_path / "d.json")], tmp_path, "--actions", "--n-depots")


def test_the_data_from_standard_input(example_csv: Path, tmp_path: Path) -> None:
    """``-`` reads the data from stdin: the same depots as from the file."""
    args = ["segment", "--dates", "0801..0810", "--json"]
    res = runner.invoke(
        app,
        [args[0], "-", *args[1:], "--out", str(tmp_path / "a.json")],
        input=example_csv.read_bytes(),
    )
    assert res.exit_code == 0, res.output
    ref = runner.invoke(
        app, [args[0], str(example_csv), *args[1:], "--out", str(tmp_path / "b.json")]
    )
    assert ref.exit_code == 0, ref.output
    a, b = (json.loads((tmp_path / n).read_text()) for n in ("a.json", "b.json"))
    assert a["depots"] == b["depots"] and a["candidates"] == b["candidates"]
    assert a["meta"]["input"]["sha256"] == b["meta"]["input"]["sha256"]


def test_empty_standard_input_is_one_line(tmp_path: Path, fails_cleanly) -> None:
    fails_cleanly(
        ["replay-day", "-", "--date", "0811", "--out", str(tmp_path / "out")],
        tmp_path,
        "standard input",
    )
    out = str(tmp_path / "a.pt")
    fails_cleanly(["train", "-", "--out", out], tmp_path, "standard input")


def test_closed_standard_input_is_called_closed(tmp_path: Path) -> None:
    """``-`` with standard input closed (a cron line's ``<&-``): one line saying so, not
    that it is a terminal."""
    import shlex
    import subprocess
    import sys

    main = "from marops_cli.cli.app import main; main()"
    args = [sys.executable, "-c", main, "segment", "-", "--out", str(tmp_path / "d.json")]
    cmd = shlex.join(args) + " <&-"
    res = subprocess.run(["bash", "-c", cmd], capture_output=True, text=True)
    assert res.returncode == 2 and not (tmp_path / "d.json").exists()
    (line,) = res.stderr.splitlines()
    assert "standard input, which is closed" in line


def test_standard_input_beyond_the_cap_is_one_line_and_no_copy_stays(
    example_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A pipe that never ends once filled the temporary disk: beyond the cap (made small
    here) it is refused naming standard input, and the partial copy is removed at once."""
    import tempfile

    import marops_cli.cli.common as common

    temp = tmp_path / "tmp"
    temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    monkeypatch.setattr(common, "MAX_STDIN", 4096)
    monkeypatch.setattr(common, "_stdin_copy", None)
    args = ["segment", "-", "--out", str(tmp_path / "d.json")]
    res = runner.invoke(app, args, input=example_csv.read_bytes())
    assert res.exit_code == 2, res.output
    (line,) = res.stderr.strip().splitlines()
    assert line.startswith("marops: error: standard input (-): more than "), line
    assert "save the data to a file" in line
    assert list(temp.iterdir()) == []
    assert not (tmp_path / "d.json").exists()


def test_a_killed_runs_copy_of_standard_input_goes_with_the_next_run(
    example_csv: Path, tmp_path: Path
) -> None:
    """kill -9 leaves standard input's copy in the temporary folder (nothing can remove
    it then): the next run that reads standard input removes it, and a finished run
    leaves none of its own. What is not a killed run's copy stays: a running process's,
    one holding another file, a folder of another name."""
    import os
    import subprocess
    import sys
    import time

    temp = tmp_path / "temp"
    temp.mkdir()
    env = {**os.environ, "TMPDIR": str(temp)}
    main = ["-c", "from marops_cli.cli.app import main; main()", "segment", "-", "-q"]
    data = example_csv.read_bytes()
    killed = subprocess.Popen(
        [sys.executable, *main, "--out", str(tmp_path / "a.json")],
        stdin=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=env,
    )
    assert killed.stdin is not None
    killed.stdin.write(data[: 3 << 19])  # the pipe stays open: it copies, then waits
    killed.stdin.flush()
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not any(
        p.stat().st_size for p in temp.glob("marops-stdin-*/stdin")
    ):
        time.sleep(0.05)
    killed.kill()
    killed.wait()
    killed.stdin.close()
    (copy,) = temp.glob("marops-stdin-*")
    assert copy.name.startswith(f"marops-stdin-{killed.pid}-")
    running = temp / f"marops-stdin-{os.getppid()}-abcd1234"  # a running process's
    theirs = temp / f"marops-stdin-{killed.pid}-efgh5678"  # holds more than a copy
    plain = temp / "marops-stdin-ijkl9012"  # no process id in its name
    made = temp / f"marops-stdin-{killed.pid}-mnop3456"  # someone's, without marops' mark
    for folder in (running, theirs, plain, made):
        folder.mkdir()
        (folder / "stdin").write_text("x")
        if folder is not made:
            (folder / ".marops-stdin").write_text(f"marops-stdin {killed.pid}\n")
    (theirs / "notes.txt").write_text("mine")
    again = subprocess.run(
        [sys.executable, *main, "--out", str(tmp_path / "b.json")],
        input=data,
        capture_output=True,
        env=env,
    )
    assert again.returncode == 0, again.stderr
    kept = [running.name, theirs.name, plain.name, made.name]
    assert sorted(p.name for p in temp.iterdir()) == sorted(kept)
    assert (theirs / "notes.txt").read_text() == "mine"
    assert (made / "stdin").read_text() == "x"


# Every command that writes, with --out under a file: one line naming the path, exit 2,
# before any work (docs/outputs.md, "What marops replaces").
OUT_UNDER_A_FILE = {
    "synth": ["synth", "--days", "1", "--out", "{bad}/lade.csv"],
    "segment": ["segment", "{data}", "--out", "{bad}/depots.json"],
    "segment --hubs": ["segment", "{data}", "--hubs", "auto", "--out", "{bad}/hubs.json"],
    "plan-window": ["plan-window", "{data}", "--depots", "{depots}", "--date", "0811"]
    + ["--window", "5", "--out", "{bad}"],
    "replay-day": ["replay-day", "{data}", "--date", "0811", "--out", "{bad}"],
    "replay-day --dates": ["replay-day", "{data}", "--dates", "0811..0812", "--out", "{bad}"],
    "train": ["train", "{data}", "--episodes", "1", "--out", "{bad}/actor.pt"],
    "evaluate": ["evaluate", "{data}", "--dates", "0811", "--out", "{bad}"],
}


@pytest.mark.parametrize("name", sorted(OUT_UNDER_A_FILE))
def test_out_under_a_file_is_one_line_up_front(
    example_csv: Path, tmp_path: Path, fails_cleanly, name: str
) -> None:
    afile = tmp_path / "afile"
    afile.write_text("not a folder")
    depots = tmp_path / "depots.json"
    depots.write_text("{}")  # never read: the outputs are checked first
    values = {"data": str(example_csv), "depots": str(depots), "bad": str(afile / "sub")}
    args = [a.format(**values) for a in OUT_UNDER_A_FILE[name]]
    line = fails_cleanly(args, tmp_path, str(afile / "sub"), "is a file")
    assert "Errno" not in line


def test_replay_day_ends_naming_the_files_it_wrote(example_csv: Path, tmp_path: Path) -> None:
    """The closing line names every file written; a re-run that keeps its days says
    so, and --json lists the same files (of one study square: a city's line names its
    count and hub folders, as the test below checks)."""
    out, one = tmp_path / "o", tmp_path / "one"
    common = ["replay-day", "--area", "square", str(example_csv), "--method", "stay"]
    common += ["--workers", "1"]
    args = [*common, "--dates", "0811..0812", "--out", str(out)]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith("wrote ")
    named = {Path(p) for p in last.removeprefix("wrote ").split(", ")}
    on_disk = {p for p in out.rglob("*") if p.is_file() and not p.name.startswith(".")}
    assert named == on_disk and len(named) == 7  # 2 days × stops, routes, metrics + totals
    res = runner.invoke(app, [*args, "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["files"] == [str(out / "metrics.json")]  # the days kept
    res = runner.invoke(app, [*common, "--date", "0811", "--out", str(one)])
    assert res.stderr.strip().splitlines()[-1] == "wrote " + ", ".join(
        str(one / n) for n in ("stops.parquet", "routes.parquet", "metrics.json")
    )
    res = runner.invoke(app, [*common, "--date", "0811", "--out", str(one)])
    assert res.stderr.strip().splitlines()[-1].startswith("nothing written:")


def test_the_closing_line_of_a_city_names_its_first_and_last_hub() -> None:
    """Many files: their count and the folders right below --out, hub-10 after hub-9
    (it named hub-0, …, hub-9/2022-08-03 of eleven hubs)."""
    from marops_cli.cli.replay_cmd import _wrote

    out = Path("city")
    files = [out / f"hub-{h}" / "2022-08-0{d}" / "stops.parquet" for h in range(11) for d in (1, 2)]
    files += [out / f"hub-{h}" / "metrics.json" for h in range(11)] + [out / "metrics.json"]
    assert _wrote(out, files) == (
        f"wrote {len(files)} files: city/metrics.json and those in city/hub-0, …, city/hub-10"
    )
    days = [out / f"2022-08-{d:02}" / n for d in range(1, 31) for n in ("a", "b")]
    assert _wrote(out, days) == (
        "wrote 60 files: city/metrics.json and those in city/2022-08-01, …, city/2022-08-30"
    )


def test_a_missing_fleet_file_is_the_only_line(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """The fleet file is checked before the drop report is said."""
    args = ["replay-day", str(example_csv), "--date", "0811", "--fleet", str(tmp_path / "f.toml")]
    fails_cleanly([*args, "--out", str(tmp_path / "o")], tmp_path, "f.toml", "not found")


def test_an_actor_given_to_evaluate_must_load(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """A mistyped --policy stops the run, also when --methods is left to its default
    (which skips only the methods this build cannot run)."""
    args = ["evaluate", str(example_csv), "--dates", "0811", "--policy", str(tmp_path / "a.pt")]
    fails_cleanly([*args, "--out", str(tmp_path / "o")], tmp_path, "a.pt", "--policy")


def test_an_error_in_standard_input_names_it_not_its_temporary_copy(tmp_path: Path) -> None:
    """Bad data piped in: the line names standard input (and the row), never the
    temporary file marops copied it to."""
    bad = b"order_id,lng,lat,accept_time,delivery_time\n1,121.47,31.23,08-01 09:00:00,later\n"
    res = runner.invoke(app, ["segment", "-", "--out", str(tmp_path / "d.json")], input=bad)
    assert res.exit_code == 2, res.output
    line = res.output.strip().splitlines()[-1]
    assert line.startswith("marops: error: standard input (-)"), line
    assert "marops-stdin-" not in res.output


def test_a_file_name_with_a_line_break_is_still_one_line(tmp_path: Path) -> None:
    missing = tmp_path / "two\nlines.csv"
    res = runner.invoke(app, ["segment", str(missing), "--out", str(tmp_path / "d.json")])
    assert res.exit_code == 2 and len(res.output.strip().splitlines()) == 1, res.output
    assert "two\\nlines.csv" in res.output


def test_the_files_written_are_one_line_whatever_their_names(
    example_csv: Path, tmp_path: Path
) -> None:
    """The closing line names the files as errors do: a line break in a name is ``\\n``."""
    out = tmp_path / "my\ndepots.json"
    res = runner.invoke(
        app, ["segment", str(example_csv), "--dates", "0801..0803", "--out", str(out)]
    )
    assert res.exit_code == 0, res.output
    (line,) = [x for x in res.output.splitlines() if x.startswith("wrote ")]
    assert line == f"wrote {tmp_path}/my\\ndepots.json"
    assert not any(x.startswith("depots.json") for x in res.output.splitlines())
    assert out.is_file()


def test_names_are_printed_as_they_are_never_as_markup_or_terminal_codes(
    example_csv: Path, tmp_path: Path
) -> None:
    """A name holding rich markup (``[red]``, ``[/]``: a MarkupError and a traceback
    once the files were written), an emoji code or a terminal's control sequence (ESC
    clears the screen) is printed as its characters, the control ones escaped."""
    (tmp_path / "a[").mkdir()
    out = tmp_path / "a[" / "][red]:bomb:\x1b[2J\u202eb.json"
    res = runner.invoke(
        app, ["segment", str(example_csv), "--dates", "0801..0803", "--out", str(out)]
    )
    assert res.exit_code == 0, res.output
    (line,) = [x for x in res.output.splitlines() if x.startswith("wrote ")]
    assert line == f"wrote {tmp_path}/a[/][red]:bomb:\\x1b[2J\\u202eb.json"
    assert out.is_file()
    res = runner.invoke(app, ["segment", str(out.with_suffix(".csv")), "--out", str(out)])
    assert res.exit_code == 2 and "\x1b" not in res.output, res.output
    assert "[red]:bomb:\\x1b[2J" in res.output


def test_segmenting_again_keeps_the_days_replayed_with_its_depots(
    example_csv: Path, tmp_path: Path
) -> None:
    """The README's worked example run twice: segment writes the same bytes again (no
    time stamp), so the replay that names the depots file keeps its day instead of
    stopping with "holds a replay made with other settings"; hubs files alike."""
    depots, hubs = tmp_path / "depots.json", tmp_path / "hubs.json"
    segment = ["segment", str(example_csv), "--dates", "0801..0810"]
    replay = ["replay-day", str(example_csv), "--depots", str(depots), "--date", "0811"]
    replay += ["--method", "stay", "--out", str(tmp_path / "day")]
    first: dict[Path, bytes] = {}
    for _ in range(2):
        for out, extra in ((depots, []), (hubs, ["--hubs", "2"])):
            res = runner.invoke(app, [*segment, *extra, "--out", str(out)])
            assert res.exit_code == 0, res.output
            assert first.setdefault(out, out.read_bytes()) == out.read_bytes(), out.name
        res = runner.invoke(app, replay)
        assert res.exit_code == 0, res.output
    assert res.stderr.strip().splitlines()[-1].startswith("nothing written:"), res.stderr


@pytest.mark.parametrize("how", ["while starting", "swallowed by a library"])
def test_ctrl_c_outside_a_command_is_one_line_and_130(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], how: str
) -> None:
    """Ctrl-C before a command handles it (as marops starts), or one a library swallowed
    half-way through its import (pyarrow importing pandas) so that a later use fails with
    another error: "marops: interrupted", exit 130, no traceback."""
    from marops_cli.cli import app as app_module
    from marops_cli.cli import common

    def run() -> int:
        if how == "while starting":
            raise KeyboardInterrupt
        common.INTERRUPTED.set()  # as the handler marops installs notes it
        raise AttributeError("partially initialized module 'pandas' has no attribute 'x'")

    left: list[object] = []
    monkeypatch.setattr(app_module, "_run", run)
    monkeypatch.setattr(app_module, "_leave", left.append)
    try:
        app_module.main()
    finally:
        common.INTERRUPTED.clear()
    assert left == [130]
    assert capsys.readouterr().err == "marops: interrupted\n"
