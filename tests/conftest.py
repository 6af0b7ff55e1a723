"""Shared fixtures: the bundled example and a scenario built from it once per session."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "shanghai_synth.csv"


@pytest.fixture(scope="session", autouse=True)
def _own_depots_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """The test run's depots cache is its own (never the user's), shared by the
    processes it starts."""
    old = os.environ.get("MAROPS_CACHE_DIR")
    os.environ["MAROPS_CACHE_DIR"] = str(tmp_path_factory.mktemp("cache"))
    yield
    if old is None:
        os.environ.pop("MAROPS_CACHE_DIR", None)
    else:
        os.environ["MAROPS_CACHE_DIR"] = old


@pytest.fixture(scope="session", autouse=True)
def _own_data_home(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """The test run's installation record of trained actors is its own (never the
    user's: marops_cli/policies/installation.py), shared by the processes it starts."""
    old = os.environ.get("XDG_DATA_HOME")
    os.environ["XDG_DATA_HOME"] = str(tmp_path_factory.mktemp("data-home"))
    yield
    if old is None:
        os.environ.pop("XDG_DATA_HOME", None)
    else:
        os.environ["XDG_DATA_HOME"] = old


@pytest.fixture(scope="session")
def example_csv() -> Path:
    assert EXAMPLE.is_file(), "examples/shanghai_synth.csv is part of the repository"
    return EXAMPLE


def _fails_cleanly(args: list[str], out_dir: Path, *needles: str) -> str:
    """Run ``marops ARGS``: exit 2, one line on stderr holding every needle, no traceback,
    and nothing new under ``out_dir``. Returns the line."""
    from marops_cli.cli.app import app

    before = set(out_dir.rglob("*"))
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 2, res.output
    err = res.stderr.strip()
    assert len(err.splitlines()) == 1, err
    assert "Traceback" not in res.output
    for n in needles:
        assert n in err, (n, err)
    assert set(out_dir.rglob("*")) == before, "something was written"
    return err


@pytest.fixture
def fails_cleanly() -> Callable[..., str]:
    """The bad-input contract of docs/outputs.md as one check (see :func:`_fails_cleanly`)."""
    return _fails_cleanly


# ``marops`` in a process of its own. Ctrl-C is as in a terminal even when the tests run
# where SIGINT is ignored (a background job): an ignored SIGINT is inherited, and Python
# then keeps it ignored.
MAIN = (
    "import signal; signal.signal(signal.SIGINT, signal.default_int_handler)\n"
    "from marops_cli.cli.app import main; main()"
)


def _stop_marops(
    args: list[str], ready: Callable[[], bool], sig: int, *, group: bool = True
) -> tuple[int, str]:
    """Start ``marops ARGS`` in its own process group, wait until ``ready()`` (some
    finished step's file exists), send ``sig`` to the group (the workers too) or, with
    ``group`` False, to the command alone; its exit code and stderr."""
    import subprocess
    import sys
    import time

    proc = subprocess.Popen(
        [sys.executable, "-c", MAIN, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, like a terminal's
    )
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and proc.poll() is None:
        if ready():
            break
        time.sleep(0.02)
    assert proc.poll() is None, "finished before it could be stopped"
    if group:
        os.killpg(proc.pid, sig)
    else:
        os.kill(proc.pid, sig)
    _, err = proc.communicate(timeout=120)
    return proc.returncode, err


@pytest.fixture
def stop_marops() -> Callable[..., tuple[int, str]]:
    """Stop a ``marops`` run half-way with a signal (see :func:`_stop_marops`)."""
    return _stop_marops
