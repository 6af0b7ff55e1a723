"""The folder lock: only the run holding it releases it (docs/outputs.md)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

LOCK = ".marops.lock"

# A run in a process of its own: takes the folder, says so, then holds it until its
# stdin closes (or fails as a refused run does, with the message on stderr).
HOLD = """
import sys
from marops_cli.errors import RunError
from marops_cli.io.atomic import folder_lock
try:
    with folder_lock(sys.argv[1]):
        print("holding", flush=True)
        sys.stdin.read()
except RunError as exc:
    print(exc, file=sys.stderr)
    sys.exit(1)
"""


def _start(folder: Path) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-c", HOLD, str(folder)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _refused(folder: Path, first: subprocess.Popen[str]) -> None:
    out, err = _start(folder).communicate(timeout=60)
    assert out == "" and f"another marops run (pid {first.pid})" in err, err


def test_a_refused_run_does_not_break_the_lock_of_the_run_holding_it(tmp_path: Path) -> None:
    folder = tmp_path / "out"
    first = _start(folder)
    try:
        assert first.stdout is not None and first.stdout.readline() == "holding\n"
        _refused(folder, first)  # the second run is refused...
        assert (folder / LOCK).exists()  # ...and leaves the lock where it was
        _refused(folder, first)  # so a third is refused too while the first runs
    finally:
        first.communicate("", timeout=60)
    assert first.returncode == 0
    assert not (folder / LOCK).exists()  # the holder removed it
    third = _start(folder)  # free again
    assert third.stdout is not None and third.stdout.readline() == "holding\n"
    third.communicate("", timeout=60)
    assert third.returncode == 0


def test_the_cli_refused_twice_while_a_run_holds_the_folder(
    example_csv: Path, tmp_path: Path
) -> None:
    folder = tmp_path / "day"
    first = _start(folder)
    args = ["replay-day", str(example_csv), "--date", "0811", "--method", "stay"]
    cmd = [sys.executable, "-c", "from marops_cli.cli.app import main; main()", *args]
    try:
        assert first.stdout is not None and first.stdout.readline() == "holding\n"
        for _ in range(2):
            res = subprocess.run([*cmd, "--out", str(folder)], capture_output=True, text=True)
            assert res.returncode == 1 and "is writing here" in res.stderr, res.stderr
            assert not (folder / "stops.parquet").exists()
    finally:
        first.communicate("", timeout=60)
