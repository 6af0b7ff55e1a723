"""Outputs checked before the work; a failed write names its file (docs/outputs.md)."""

from __future__ import annotations

import errno
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from marops_cli.errors import RunError
from marops_cli.io import output_set

MAIN = "from marops_cli.cli.app import main; main()"


@pytest.fixture
def read_only(tmp_path: Path) -> Path:
    """A folder this user cannot write: mode 0555, or where root writes anyway, /sys."""
    folder = tmp_path / "read-only"
    folder.mkdir()
    folder.chmod(0o555)
    for candidate in (folder, Path("/sys")):
        try:
            fd, probe = tempfile.mkstemp(dir=candidate)
        except OSError:
            return candidate
        os.close(fd)
        os.unlink(probe)
    pytest.skip("no folder here refuses this user's writes")


def test_train_into_a_read_only_folder_stops_before_training(
    example_csv: Path, read_only: Path
) -> None:
    out = read_only / "p.pt"
    args = ["train", example_csv, "--episodes", "50", "--out", out]
    res = subprocess.run(
        [sys.executable, "-c", MAIN, *map(str, args)], capture_output=True, text=True, timeout=120
    )
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    assert lines[0].startswith(f"marops: error: {out}: cannot write (")
    assert "episode" not in res.stderr.lower()  # nothing trained


@pytest.mark.parametrize(
    ("code", "reason"),
    [
        (errno.ENOSPC, "No space left on device"),
        (errno.EROFS, "Read-only file system"),
        (errno.EACCES, "Permission denied"),
    ],
)
def test_a_failed_write_names_the_file(tmp_path: Path, code: int, reason: str) -> None:
    final = tmp_path / "summary.csv"

    def fails(tmp: Path) -> None:
        tmp.write_bytes(b"half")
        raise OSError(code, os.strerror(code))

    with pytest.raises(RunError) as caught, output_set() as files:
        files.write_with(final, fails)
    assert str(caught.value) == f"{final}: cannot write ({reason})"
    assert list(tmp_path.iterdir()) == []  # nothing half-written stays


def test_a_failed_set_removes_the_folders_it_made_and_no_other(tmp_path: Path) -> None:
    """The folders made for a set that fails go with it (a full disk left ``a/b``
    behind), the ones that were there stay, and so does one that now holds a user's file."""
    (tmp_path / "kept").mkdir()
    (tmp_path / "x" / "y").mkdir(parents=True)
    user = tmp_path / "x" / "y" / "notes.txt"

    def fails(tmp: Path) -> None:
        user.write_text("mine")  # another program writes into a folder meanwhile
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with pytest.raises(RunError), output_set() as files:
        files.write_bytes(tmp_path / "kept" / "a" / "b" / "one.csv", b"1")
        files.write_bytes(tmp_path / "x" / "y" / "z" / "two.csv", b"2")
        files.write_with(tmp_path / "x" / "y" / "three.csv", fails)
    assert sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*")) == [
        "kept",
        "x",
        "x/y",
        "x/y/notes.txt",
    ]


def test_a_full_disk_while_writing_names_the_file(tmp_path: Path) -> None:
    final = tmp_path / "routes.png"

    def to_full_disk(tmp: Path) -> None:
        with open("/dev/full", "wb") as fh:  # every write: ENOSPC
            fh.write(b"x" * 65536)
            fh.flush()

    if not Path("/dev/full").exists():
        pytest.skip("no /dev/full")
    full = r"routes\.png: cannot write \(No space left on device\)"
    with pytest.raises(RunError, match=full), output_set() as files:
        files.write_with(final, to_full_disk)
    assert not final.exists()


def test_a_failed_rename_names_the_file(tmp_path: Path, monkeypatch) -> None:
    final = tmp_path / "stops.parquet"

    def refuse(src: object, dst: object) -> None:
        raise OSError(errno.EROFS, os.strerror(errno.EROFS))

    monkeypatch.setattr(os, "replace", refuse)
    read_only = r"stops\.parquet: cannot write \(Read-only file system\)"
    with pytest.raises(RunError, match=read_only), output_set() as files:
        files.write_bytes(final, b"x")
    assert list(tmp_path.iterdir()) == []
