"""Output for cron jobs and pipes: plain lines, no box drawing, --json, one-line errors."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BOX = set("─│┃━┏┓┗┛┡┩╭╮╰╯┌┐└┘├┤┬┴┼═║")


def run(args: list[str], cwd: Path, **env: str) -> subprocess.CompletedProcess[str]:
    """The console script as cron runs it: no terminal, a bare environment, no stdin."""
    base = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": str(cwd)}
    # This checkout's marops, whichever one is installed.
    code = (
        f"import sys; sys.path.insert(0, {str(ROOT)!r}); "
        "from marops_cli.cli.app import main; main()"
    )
    return subprocess.run(
        [sys.executable, "-c", code, *args],
        cwd=cwd,
        env=base | env,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.fixture(scope="module")
def cron_run(example_csv: Path, tmp_path_factory: pytest.TempPathFactory):
    cwd = tmp_path_factory.mktemp("cron")
    args = ["replay-day", "--area", "square", str(example_csv), "--date", "0811"]
    args += ["--method", "stay"]
    table = run([*args, "--out", "table"], cwd)
    as_json = run([*args, "--out", "json", "--json"], cwd)
    return cwd, table, as_json


def test_plain_tables_and_whole_lines_without_a_terminal(cron_run) -> None:
    _, res, _ = cron_run
    assert res.returncode == 0, res.stderr
    assert not BOX & set(res.stdout + res.stderr)
    # the drop report is one line however long, never wrapped mid sentence
    report = [ln for ln in res.stderr.splitlines() if "rows read" in ln]
    assert len(report) == 1 and report[0].endswith("--strict makes these errors")
    lines = [ln.split() for ln in res.stdout.splitlines()]
    assert ["day", "method", "energy"] in [ln[:3] for ln in lines]  # the header, whole
    assert ["2022-08-11", "stay"] in [ln[:2] for ln in lines]  # a row: columns, not cells
    assert "\x1b[" not in res.stdout + res.stderr  # no colour codes


def test_a_day_without_a_terminal_logs_one_line_not_one_per_window(cron_run) -> None:
    """A cron job's log: the day's line (its orders due, planned and left out), not a
    progress line per window (sixteen a day)."""
    _, res, _ = cron_run
    assert res.returncode == 0, res.stderr
    said = [ln for ln in res.stderr.splitlines() if ln.startswith("2022-08-11")]
    assert len(said) == 1 and "orders due" in said[0], res.stderr
    assert not [ln for ln in res.stderr.splitlines() if " window " in ln], res.stderr


def test_json_prints_the_summary_on_stdout_only(cron_run) -> None:
    cwd, table, res = cron_run
    assert res.returncode == 0, res.stderr
    doc = json.loads(res.stdout)
    assert doc["command"] == "replay-day" and doc["out"] == "json"
    (day,) = doc["days"]
    written = json.loads((cwd / "json" / "metrics.json").read_text())["days"][0]
    assert day == written
    assert "window" not in res.stderr  # no progress lines
    assert table.stdout.count(str(day["delivered"])) >= 1


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["replay-day", "--bogus"], "No such option: --bogus"),
        (["replay-day"], "Missing argument"),
        (["segment", "x.csv", "--out", "d.json", "--n-depots", "many"], "--n-depots"),
        # an option without its value: click's parser raised it without the command
        (["replay-day", "x.csv", "--date"], "'--date' requires an argument. (see '"),
        # a bare marops: the commands in one line, not 20 lines of help with exit 2
        ([], "Missing command: one of synth, segment, plan-window, replay-day, train,"),
        (["--debug"], "Missing command: one of synth,"),
    ],
)
def test_usage_errors_are_one_plain_line(tmp_path: Path, args: list[str], needle: str) -> None:
    res = run(args, tmp_path)
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("marops: error: ") and needle in lines[0]
    assert not BOX & set(res.stderr)


@pytest.mark.parametrize(
    ("args", "env", "needle"),
    [
        (["segment", "missing.csv", "--out", "d.json", "--json"], {}, "missing.csv: file not"),
        (["replay-day", "missing.csv", "--date", "0811", "--out", "o"], {"MAROPS_JSON": "1"}, ""),
        # before the command runs: a usage error of a command that has --json
        (["segment", "x.csv", "--out", "d.json", "--json", "--n-depots", "many"], {}, "--n-"),
        (["report", "--json", "--bogus", "."], {}, "No such option: --bogus"),
        (["segmnt", "x.csv", "--json"], {}, "No such command 'segmnt'"),
        (["replay-day", "x.csv", "--json", "--date"], {}, "'--date' requires an argument"),
        (["segment", "x.csv", "--out"], {"MAROPS_JSON": "1"}, "'--out' requires an argument"),
    ],
    ids=[
        "in-the-command",
        "from-the-environment",
        "bad-value",
        "unknown-option",
        "unknown-command",
        "no-value",
        "no-value-from-the-environment",
    ],
)
def test_json_errors_are_one_document_on_stdout(
    tmp_path: Path, args: list[str], env: dict[str, str], needle: str
) -> None:
    """With --json an error is still one JSON document on stdout (command, error, exit
    code), while stderr keeps its one line."""
    res = run(args, tmp_path, **env)
    assert res.returncode == 2
    doc = json.loads(res.stdout)
    assert doc == {"command": args[0], "error": doc["error"], "exit_code": 2}
    assert needle in doc["error"]
    assert res.stderr.strip().splitlines() == [f"marops: error: {doc['error']}"]


def test_a_bare_marops_with_json_is_one_document(tmp_path: Path) -> None:
    res = run([], tmp_path, MAROPS_JSON="1")
    assert res.returncode == 2
    doc = json.loads(res.stdout)
    assert doc["exit_code"] == 2 and doc["error"].startswith("Missing command: one of synth")
    assert res.stderr.strip().splitlines() == [f"marops: error: {doc['error']}"]


@pytest.mark.parametrize(
    ("where", "sig", "args", "env"),
    [
        ("Command", "SIGINT", ["segment", "x.csv", "--out", "d.json", "--json"], {}),
        ("Command", "SIGTERM", ["--debug", "replay-day", "x.csv"], {"MAROPS_JSON": "1"}),
        ("Group", "SIGINT", ["report", "--json", "."], {}),
        ("Command", "SIGTERM", ["train", "x.csv", "--out", "a.pt"], {"MAROPS_JSON": "1"}),
    ],
    ids=["ctrl-c", "sigterm-json-from-the-environment", "ctrl-c-before-the-command", "no-json"],
)
def test_a_stop_while_the_command_line_is_read_writes_the_json_document(
    tmp_path: Path, where: str, sig: str, args: list[str], env: dict[str, str]
) -> None:
    """Ctrl-C or SIGTERM as marops reads the command line (the signal sent from inside its
    parser): the line and exit code of any stop, and with --json the document a stop
    during the command writes (train has no --json: stdout stays empty)."""
    code = (
        f"import os, signal, sys; sys.path.insert(0, {str(ROOT)!r})\n"
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "from marops_cli.cli import usage\n"
        f"kind = usage.{where}\n"
        "parse = kind.parse_args\n"
        "def parse_args(self, ctx, args):\n"
        f"    os.kill(os.getpid(), signal.{sig})\n"
        "    return parse(self, ctx, args)\n"
        "kind.parse_args = parse_args\n"
        "from marops_cli.cli.app import main; main()\n"
    )
    base = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": str(tmp_path)}
    res = subprocess.run(
        [sys.executable, "-c", code, *args],
        cwd=tmp_path,
        env=base | env,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=300,
    )
    line, status = ("terminated", 143) if sig == "SIGTERM" else ("interrupted", 130)
    assert res.returncode == status
    assert res.stderr.strip().splitlines() == [f"marops: {line}"]
    command = next(a for a in args if not a.startswith("-"))
    if command == "train":
        assert res.stdout == ""
    else:
        assert json.loads(res.stdout) == {"command": command, "error": line, "exit_code": status}


@pytest.mark.parametrize(
    "args",
    [
        ["segment", "missing.csv", "--out", "d.json"],
        ["synth", "--days", "0", "--out", "s.csv"],  # no --json: nothing to print it
        ["synth", "--days", "1", "--json", "--out", "s.csv"],
        ["segment", "missing.csv", "--out", "d.json", "--", "--json"],
    ],
    ids=["no-json", "command-without-json", "json-unknown-to-the-command", "after-dashes"],
)
def test_errors_without_json_leave_stdout_empty(tmp_path: Path, args: list[str]) -> None:
    res = run(args, tmp_path)
    assert res.returncode == 2 and res.stdout == ""
    assert len(res.stderr.strip().splitlines()) == 1


def test_quiet_keeps_warnings_only(example_csv: Path, tmp_path: Path) -> None:
    args = ["replay-day", str(example_csv), "--date", "0811", "--method", "stay"]
    res = run([*args, "--drones", "1", "--out", "o", "--quiet"], tmp_path)
    assert res.returncode == 0, res.stderr
    assert res.stdout == ""  # no metrics table: the day's metrics are in metrics.json
    assert res.stderr.strip().splitlines() == [
        ln for ln in res.stderr.strip().splitlines() if ln.startswith("warning: ")
    ]
    # a city's hub-days short of drones: one line for them all, naming the worst
    warned = [ln for ln in res.stderr.splitlines() if "stayed undelivered" in ln]
    assert len(warned) == 1 and " hub-days: more than 10% of their requests" in warned[0]
    assert "the most hub " in warned[0] and "(metrics.json)" in warned[0], warned
    # settings from the environment (MAROPS_*): the same run, its fleet size from MAROPS_DRONES
    env = run([*args, "--out", "e", "--json"], tmp_path, MAROPS_DRONES="1")
    assert json.loads(env.stdout)["days"][0]["drones"] == 1


def test_help_lists_every_method_and_one_vocabulary() -> None:
    """Every method is named in help; --depots is a file and counts are --n-depots."""
    from typer.testing import CliRunner

    from marops_cli.cli.app import app
    from marops_cli.cli.options import METHOD_NAMES
    from marops_cli.methods import METHODS

    assert METHOD_NAMES.split(", ") == list(METHODS)
    runner = CliRunner()
    for cmd in ("replay-day", "plan-window"):
        text = " ".join(runner.invoke(app, [cmd, "-h"]).output.replace("│", " ").split())
        assert "myopic" in text and "[default: marops]" in text
    for cmd in ("segment", "replay-day", "evaluate", "train"):
        text = runner.invoke(app, [cmd, "--help"]).output
        assert "--depots-n" not in text
        if cmd != "evaluate" and cmd != "train":
            assert "--n-depots" in text


def test_a_method_is_one_registry_entry(example_csv: Path, tmp_path: Path) -> None:
    """Registering a toy method makes it valid in help, replay-day and evaluate."""
    code = (
        "from marops_cli.methods import Method, register; "
        "register(Method('toy', 'squares', 'greedy', 'greedy on a square grid')); "
        "from marops_cli.cli.app import main; main()"
    )

    def cli(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, "-c", code, *args], cwd=tmp_path, capture_output=True, text=True
        )

    assert "myopic, toy" in " ".join(cli("replay-day", "--help").stdout.split())
    one = ("--area", "square", str(example_csv), "--date", "0811")
    res = cli("replay-day", *one, "--method", "toy", "--out", "d")
    assert res.returncode == 0, res.stderr
    doc = json.loads((tmp_path / "d" / "metrics.json").read_text())
    assert (
        doc["days"][0]["method"] == "toy"
        and doc["meta"]["config"]["segment"]["method"] == "squares"
    )
    res = cli("evaluate", str(example_csv), "--methods", "toy,stay", "--dates", "0811", "--no-plot")
    assert res.returncode == 2 and "--out" in res.stderr  # (usage: --out is required)
    res = cli(
        "evaluate",
        "--area",
        "square",
        str(example_csv),
        "--methods",
        "toy,stay",
        "--dates",
        "0811",
        "--no-plot",
        "--out",
        "ev",
        "--json",
        "-q",
    )
    assert res.returncode == 0, res.stderr
    doc = json.loads(res.stdout, parse_constant=_no_nan)  # strict JSON: no NaN literals
    assert {r["method"] for r in doc["summary"]} == {"toy", "stay"}
    assert doc["summary"][0]["avg_delay_h_std"] is None  # one day: no spread, null


def _no_nan(token: str) -> None:
    raise AssertionError(f"{token} is not JSON")


def test_cron_json_is_one_document_for_every_command(example_csv: Path, tmp_path: Path) -> None:
    """``env -i PATH=… HOME=… marops … --json </dev/null``: stdout is one JSON document
    and nothing else, for segment and plan-window as for replay-day; the plain run's
    messages are whole lines without colour."""
    seg = run(
        ["segment", str(example_csv), "--dates", "0801..0810", "--out", "d.json", "--json"],
        tmp_path,
    )
    assert seg.returncode == 0, seg.stderr
    assert json.loads(seg.stdout)["command"] == "segment" and seg.stderr == ""
    args = ["plan-window", str(example_csv), "--depots", "d.json", "--date", "0811"]
    args += ["--window", "5", "--method", "greedy"]
    doc = run([*args, "--out", "w", "--json"], tmp_path)
    assert doc.returncode == 0, doc.stderr
    parsed = json.loads(doc.stdout)  # one document: trailing text would fail here
    assert parsed["command"] == "plan-window" and "rows" in parsed and "orders" in parsed
    plain = run([*args, "--out", "p"], tmp_path)
    assert plain.returncode == 0, plain.stderr
    assert "\x1b[" not in plain.stdout + plain.stderr and not BOX & set(plain.stdout)
    assert any(line.startswith("wrote ") for line in plain.stderr.splitlines())
