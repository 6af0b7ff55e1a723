"""Starting the CLI loads no heavy library: they load in the command that needs them."""

from __future__ import annotations

import json
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
# Loaded only by the commands that use them; dask and distributed only with --scheduler
# (an optional extra, README.md "Sweeps on a cluster").
HEAVY = ("torch", "cvxpy", "highspy", "sklearn", "scipy", "matplotlib", "dask", "distributed")


def test_cli_start_loads_no_heavy_module() -> None:
    code = (
        "import json, sys; import marops_cli.cli.app; "
        f"print(json.dumps(sorted(m for m in {HEAVY!r} if m in sys.modules)))"
    )
    res = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout) == []


# What the command line itself needs is typer and rich: the data reader's libraries
# (numpy, pyarrow), the settings' models (pydantic) and torch load in the commands.
NOT_AT_START = ("torch", "numpy", "pyarrow", "pandas", "pydantic", "numba")


@pytest.mark.parametrize("flag", ["--help", "-V"])
def test_help_and_version_load_no_library_of_the_commands(flag: str) -> None:
    """``marops --help`` and ``marops -V`` run as the console script does (its exit
    handlers report what was loaded; docs/decisions.md, "Start-up and exit")."""
    watched = (*NOT_AT_START, *HEAVY)
    code = (
        "import atexit, json, sys\n"
        "atexit.register(lambda: print(json.dumps(sorted(m for m in "
        f"{watched!r} if m in sys.modules)), file=sys.stderr))\n"
        f"sys.argv = ['marops', {flag!r}]\n"
        "from marops_cli.cli.app import main; main()"
    )
    res = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert res.returncode == 0, res.stderr
    assert "marops" in res.stdout
    assert json.loads(res.stderr.strip().splitlines()[-1]) == []


def test_python_m_runs_the_command(tmp_path: Path) -> None:
    """``python -m marops_cli`` is the ``marops`` command, exit codes and one-line errors
    included (for a notebook's kernel or a cron job without the console script)."""

    def run(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, "-m", "marops_cli", *args],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=120,
        )

    ok = run("-V")
    assert ok.returncode == 0, ok.stderr
    assert ok.stdout.startswith("marops ")
    bad = run("segment")
    assert bad.returncode == 2
    assert bad.stderr.count("\n") == 1 and "Missing argument 'DATA'" in bad.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("how", ["python -m", "console script"])
def test_ctrl_c_while_the_command_line_loads_is_one_line(how: str) -> None:
    """Ctrl-C in the first tenths of a second, before the command takes Ctrl-C itself,
    printed the traceback of the import it stopped (here rich's, as a terminal's Ctrl-C
    would) and ended the process by the signal; now one line and exit 130, as later on."""
    entry = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]["marops"]
    module, function = entry.split(":")
    start = {
        "python -m": "import runpy; runpy.run_module('marops_cli', run_name='__main__')",
        "console script": f"from {module} import {function}; {function}()",
    }[how]
    code = (
        "import sys\n"
        "class Stop:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'rich.table':\n"
        "            raise KeyboardInterrupt\n"
        "sys.meta_path.insert(0, Stop())\n"
        "sys.argv = ['marops', '--help']\n"
        f"{start}\n"
    )
    res = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert (res.returncode, res.stderr) == (130, "marops: interrupted\n")


@pytest.mark.parametrize(
    ("signal_name", "status", "line"),
    [("SIGINT", 130, "marops: interrupted\n"), ("SIGTERM", 143, "marops: terminated\n")],
)
def test_a_stop_while_the_command_line_is_read_is_one_line(
    signal_name: str, status: int, line: str
) -> None:
    """Ctrl-C or SIGTERM while typer reads the command line, before the command takes
    it, ended with a bare exit 130 (no line; SIGTERM's 130, not 143): typer turns it
    into that exit code itself. Here the signal's handler runs as the arguments are
    parsed, as it does when the signal arrives then."""
    code = (
        "import signal, sys\n"
        "from marops_cli.cli import usage\n"
        "parse = usage.Command.parse_args\n"
        "def parse_args(self, ctx, args):\n"
        f"    signal.getsignal(signal.{signal_name})(signal.{signal_name}, None)\n"
        "    return parse(self, ctx, args)\n"
        "usage.Command.parse_args = parse_args\n"
        "sys.argv = ['marops', 'segment', 'lade.csv', '--out', 'depots.json']\n"
        "from marops_cli.cli.app import main; main()\n"
    )
    res = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert (res.returncode, res.stderr) == (status, line)


def test_distributed_is_optional_but_tested() -> None:
    """The base install leaves distributed out; the cluster, test and dev extras bring it."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert not any(d.startswith(("distributed", "dask")) for d in project["dependencies"])
    for extra in ("cluster", "test", "dev"):
        assert any(d.startswith("distributed") for d in project["optional-dependencies"][extra])


def test_replay_with_depots_loads_only_what_it_plans_with(
    example_csv: Path, tmp_path: Path
) -> None:
    """A replay with a depots file segments nothing (no scikit-learn), selects without
    cvxpy (the default solver hands HiGHS the program), draws nothing (no matplotlib);
    torch only for a recurrent actor: the realistic model's landing actor (marops, the
    default operating model) is 16 numbers read with NumPy, and naming it in the
    outputs' metadata loads no torch either (docs/decisions.md, "Start-up and exit")."""
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    depots = tmp_path / "depots.json"
    seg = ["segment", str(example_csv), "--dates", "0801..0810", "--out", str(depots)]
    assert CliRunner().invoke(app, seg).exit_code == 0
    loaded = {}
    for method in ("myopic", "marops"):
        args = ["replay-day", str(example_csv), "--date", "0811", "--depots", str(depots)]
        args += ["--method", method, "--out", str(tmp_path / method), "-q"]
        code = (
            "import json, sys\n"
            "from typer.testing import CliRunner\n"
            "from marops_cli.cli.app import app\n"
            f"res = CliRunner().invoke(app, {args!r})\n"
            "assert res.exit_code == 0, res.output\n"
            f"print(json.dumps(sorted(m for m in {HEAVY!r} if m in sys.modules)))"
        )
        res = subprocess.run(
            [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300
        )
        assert res.returncode == 0, res.stderr
        loaded[method] = json.loads(res.stdout.strip().splitlines()[-1])
    assert loaded["myopic"] == ["highspy", "scipy"]
    assert "torch" not in loaded["marops"], "the landing actor's day imported torch"
    assert loaded["marops"] == ["highspy", "scipy"]
    # The day flew the shipped landing actor (not a rule that needs no actor file).
    meta = json.loads((tmp_path / "marops" / "metrics.json").read_text())["meta"]
    assert meta["policy"]["name"] == "marops-ops.safetensors"


def test_the_methods_that_load_torch_are_named() -> None:
    """Workers' fork server preloads torch only for a run that flies an actor that
    needs it (a recurrent one)."""
    from marops_cli.sim.scenario import loads_actor

    assert loads_actor("marops") and loads_actor("squares") and loads_actor("mappo")
    assert not any(loads_actor(m) for m in ("stay", "myopic", "ops-global", "no-such"))
    assert loads_actor("stay", "torchscript:a.pt") and loads_actor("stay", "policies/a.pt")
    assert not loads_actor("marops", "greedy")
    # Under the realistic operating model marops flies the landing actor: no torch.
    assert not loads_actor("marops", paper=False)
    assert loads_actor("mappo", paper=False)  # no landing actor: the recurrent one
    shipped = ROOT / "policies"
    assert not loads_actor("stay", str(shipped / "marops-ops.safetensors"), paper=False)
    assert loads_actor("stay", str(shipped / "marops-basic.safetensors"), paper=False)


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_a_stop_that_lands_in_a_finaliser_still_stops_the_run(sig: str) -> None:
    """Ctrl-C or SIGTERM whose handler ran in a finaliser or weakref callback (seen as an
    evaluation freed its objects) was printed as an ignored exception with a traceback,
    and the run went on to its end and exit 0; now it stops the run as anywhere else."""
    code = f"""
import os, signal, sys
from marops_cli.cli import app as a
signal.signal(signal.SIGINT, a._interrupt)
signal.signal(signal.SIGTERM, a._terminate)
sys.unraisablehook = a._unraisable
class Freed:
    def __del__(self):
        os.kill(os.getpid(), signal.{sig})
        for _ in range(100_000):
            pass
try:
    Freed()
    for _ in range(10_000_000):
        pass
    print("ran on")
except KeyboardInterrupt as exc:
    print("stopped", type(exc).__name__)
"""
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    name = "Terminated" if sig == "SIGTERM" else "KeyboardInterrupt"
    assert res.stdout.strip() == f"stopped {name}", (res.stdout, res.stderr)
    assert "Traceback" not in res.stderr and "ignored" not in res.stderr, res.stderr


def test_a_stop_sent_again_is_not_sent_once_the_run_took_one_or_ends(monkeypatch) -> None:
    """The signal a finaliser swallowed is sent again only while it can still stop the
    run: not once the command reported a stop, nor while the process ends (it would cut
    the exit handlers short)."""
    import signal

    from marops_cli.cli import app as a
    from marops_cli.cli.common import STATE

    sent: list[int] = []
    monkeypatch.setattr(a.os, "kill", lambda pid, sig: sent.append(sig))
    monkeypatch.setitem(STATE, "stopped", False)
    a._again(signal.SIGINT)
    assert sent == [signal.SIGINT]
    monkeypatch.setitem(STATE, "stopped", True)
    a._again(signal.SIGINT)
    monkeypatch.setitem(STATE, "stopped", False)
    monkeypatch.setattr(a, "_LEAVING", a.threading.Event())
    a._LEAVING.set()
    a._again(signal.SIGTERM)
    assert sent == [signal.SIGINT]
