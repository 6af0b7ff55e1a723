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
    args = ["replay-day", "--area", "square", str(example_csv), "--date", "0811"]
    args += ["--method", "stay"]
    cmd = [sys.executable, "-c", "from marops_cli.cli.app import main; main()", *args]
    try:
        assert first.stdout is not None and first.stdout.readline() == "holding\n"
        for _ in range(2):
            res = subprocess.run([*cmd, "--out", str(folder)], capture_output=True, text=True)
            assert res.returncode == 1 and "is writing here" in res.stderr, res.stderr
            assert not (folder / "stops.parquet").exists()
    finally:
        first.communicate("", timeout=60)


def test_a_file_of_the_lock_s_name_that_marops_did_not_write_is_left_as_it_is(
    tmp_path: Path,
) -> None:
    from marops_cli.errors import InputError
    from marops_cli.io.atomic import folder_lock

    folder = tmp_path / "out"
    folder.mkdir()
    mine = folder / LOCK
    mine.write_text("my notes\n")
    try:
        with folder_lock(folder):
            raise AssertionError("the folder was taken")
    except InputError as exc:
        assert f"{mine}: a file of this name that marops did not write" in str(exc)
    assert mine.read_text() == "my notes\n"
    mine.unlink()
    target = tmp_path / "elsewhere.txt"
    target.write_text("keep\n")
    mine.symlink_to(target)  # never followed: the file it names is not truncated
    try:
        with folder_lock(folder):
            raise AssertionError("the folder was taken")
    except InputError as exc:
        assert "did not write" in str(exc)
    assert target.read_text() == "keep\n" and mine.is_symlink()
    mine.unlink()
    mine.write_bytes(b"\xff\xfe\x00binary")  # not text at all: left as it is too
    try:
        with folder_lock(folder):
            raise AssertionError("the folder was taken")
    except InputError as exc:
        assert "did not write" in str(exc)
    assert mine.read_bytes() == b"\xff\xfe\x00binary"
    mine.unlink()
    mine.write_text("pid 12345")  # a killed run's lock is taken over and removed
    with folder_lock(folder):
        assert mine.read_text() == f"pid {__import__('os').getpid()}"
    assert not mine.exists()


def test_a_run_inside_or_above_a_running_run_s_folder_is_refused_naming_it(
    tmp_path: Path,
) -> None:
    """Two runs never share one tree: a folder inside the held one, or one holding it, is
    refused (exit 2) naming the folder the other run writes into; the holder's lock and
    files stay."""
    from marops_cli.errors import InputError
    from marops_cli.io.atomic import folder_lock

    outer, inner = tmp_path / "o", tmp_path / "o" / "2022-08-11"
    for held, mine in ((outer, inner), (inner, outer)):
        first = _start(held)
        try:
            assert first.stdout is not None and first.stdout.readline() == "holding\n"
            try:
                with folder_lock(mine):
                    raise AssertionError("the folder was taken")
            except InputError as exc:
                assert exc.file is not None and Path(exc.file).resolve() == held.resolve()
                assert f"another marops run (pid {first.pid})" in exc.message
                assert "wait for it to finish or choose another --out" in exc.message
            assert (held / LOCK).exists() and not (mine / LOCK).exists()
        finally:
            first.communicate("", timeout=60)
        assert first.returncode == 0
    with folder_lock(outer), folder_lock(inner):  # one process's own folders: taken
        pass


def test_replay_day_into_a_day_folder_of_a_running_replay_is_refused(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """``replay-day --dates … --out o`` running, ``replay-day --date 0811 --out
    o/2022-08-11`` stops with one line naming o, exit 2, and writes nothing."""
    out = tmp_path / "o"
    first = _start(out)
    try:
        assert first.stdout is not None and first.stdout.readline() == "holding\n"
        args = ["replay-day", str(example_csv), "--date", "0811", "--method", "stay"]
        line = fails_cleanly([*args, "--out", str(out / "2022-08-11")], tmp_path, str(out))
        assert f"another marops run (pid {first.pid}) is writing into this folder" in line
    finally:
        first.communicate("", timeout=60)


def test_plan_window_into_a_running_run_s_folder_is_refused_before_planning(
    example_csv: Path, tmp_path: Path
) -> None:
    """As replay-day and evaluate: the refusal is the one line a refused run prints,
    where plan-window read the data, planned the window and said so first."""
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    depots = tmp_path / "depots.json"
    made = CliRunner().invoke(app, ["segment", str(example_csv), "--out", str(depots)])
    assert made.exit_code == 0, made.output
    out = tmp_path / "w"
    first = _start(out)
    try:
        assert first.stdout is not None and first.stdout.readline() == "holding\n"
        args = ["plan-window", str(example_csv), "--depots", str(depots), "--date", "0811"]
        res = CliRunner().invoke(app, [*args, "--window", "5", "--out", str(out)])
        assert res.exit_code == 1
        assert res.stderr.splitlines() == [
            f"marops: error: {out}: another marops run (pid {first.pid}) is writing here; "
            "wait for it to finish or choose another --out"
        ]
    finally:
        first.communicate("", timeout=60)
    assert not out.exists()  # nothing of plan-window's: the holder removed its folder


def test_a_file_where_the_locked_folder_goes_is_one_line_naming_it(tmp_path: Path) -> None:
    """A file (or a pipe) by the folder's name: exit 2 naming it, not ``File exists``, and
    the file as it was."""
    import pytest

    from marops_cli.errors import InputError
    from marops_cli.io.atomic import folder_lock

    taken = tmp_path / "hub-0"
    taken.write_text("mine")
    with pytest.raises(InputError, match="is a file where marops makes a folder") as err:
        folder_lock(taken).__enter__()
    assert err.value.file == str(taken) and taken.read_text() == "mine"


def test_a_failed_run_leaves_none_of_the_empty_folders_it_made(tmp_path: Path) -> None:
    """``--out new/a/b/c`` of a run that fails (or is stopped) before writing: ``c`` goes,
    and so do ``new/a/b``, ``new/a`` and ``new``, which the run made too; a folder that
    existed, or holds something, stays."""
    import pytest

    from marops_cli.io.atomic import folder_lock

    with pytest.raises(KeyboardInterrupt), folder_lock(tmp_path / "new" / "a" / "b" / "c"):
        raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "new" / "a").mkdir(parents=True)
    (tmp_path / "new" / "mine.txt").write_text("mine")
    with pytest.raises(KeyboardInterrupt), folder_lock(tmp_path / "new" / "a" / "b" / "c"):
        raise KeyboardInterrupt
    assert sorted(p.name for p in (tmp_path / "new").iterdir()) == ["a", "mine.txt"]
    assert list((tmp_path / "new" / "a").iterdir()) == []


def test_segment_synth_and_train_into_a_running_run_s_folder_are_refused(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """The commands that write files, not a folder (``segment``, ``synth``, ``train``),
    take no lock of their own, but a file of theirs in a folder a run holds (or below
    it) would land among that run's files or replace one as it writes it (a replay's
    summary ``metrics.json`` replaced by a depots file, exit 0 both): one line naming
    the held folder, exit 2, nothing written."""
    out = tmp_path / "o"
    first = _start(out)
    try:
        assert first.stdout is not None and first.stdout.readline() == "holding\n"
        for args in (
            ["synth", "--days", "1", "--out", str(out / "2022-08-11" / "stops.parquet")],
            ["segment", str(example_csv), "--out", str(out / "metrics.json")],
            ["segment", str(example_csv), "--hubs", "2", "--out", str(out / "h" / "hubs.json")],
            ["train", str(example_csv), "--episodes", "1", "--out", str(out / "p" / "x.pt")],
        ):
            line = fails_cleanly(args, tmp_path, str(out))
            assert f"another marops run (pid {first.pid}) is writing into this folder" in line
    finally:
        first.communicate("", timeout=60)
    assert first.returncode == 0


def test_report_on_a_folder_a_run_is_writing_says_so(tmp_path: Path) -> None:
    """``report DIR`` while a run still writes into DIR (its evaluation not yet summed
    up) said DIR held no marops outputs to report on; now it names the run writing
    there, as a second run into that folder is told, and writes nothing."""
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    out = tmp_path / "o"
    first = _start(out)
    try:
        assert first.stdout is not None and first.stdout.readline() == "holding\n"
        before = set(out.rglob("*"))
        res = CliRunner().invoke(app, ["report", str(out)])
        assert f"another marops run (pid {first.pid}) is writing here" in res.stderr
        assert res.stderr.count("\n") == 1 and "Traceback" not in res.output
        assert set(out.rglob("*")) == before
    finally:
        first.communicate("", timeout=60)
