"""The actors this installation trained: the SHA-256 of every TorchScript file ``marops
train`` wrote, one JSON line each, in ``$XDG_DATA_HOME/marops/trained-actors.jsonl``
(default ``~/.local/share/marops``). Such a file runs only code this installation wrote,
so it loads without ``--trust-actor`` (docs/method.md §6, "Trust model of actor files").

The record is only appended to (one short line per write, with ``O_APPEND``), so runs
training at once never lose each other's lines and no temporary is needed. A record
that cannot be written (a symbolic link included, never followed) is skipped, and
``train`` warns: the actor then needs its weights file or the flag.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import os
import stat
from pathlib import Path

RECORD = "trained-actors.jsonl"
MAX_RECORD = 64 << 20
"""Bytes of the record read at most (about 400,000 trained actors)."""


def record_path() -> Path:
    """``$XDG_DATA_HOME/marops/trained-actors.jsonl`` (``~/.local/share`` by default). A
    relative ``XDG_DATA_HOME`` is invalid (XDG Base Directory) and ignored: a folder
    brought along with an actor, where the run starts, never vouches for it."""
    base = os.environ.get("XDG_DATA_HOME", "").strip()
    root = Path(base) if base and Path(base).is_absolute() else Path.home() / ".local" / "share"
    return root / "marops" / RECORD


def sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def record_trained(actor: bytes, path: str | Path) -> bool:
    """Note that this installation wrote the TorchScript file ``actor`` (its bytes) to
    ``path``; False when the record could not be written (or is a symbolic link, never
    followed: the line would land in whatever file it leads to)."""
    line = json.dumps(
        {
            "sha256": sha256_bytes(actor),
            "file": str(Path(path).resolve()),
            "trained": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        },
        sort_keys=True,
    )
    record = record_path()
    try:
        record.parent.mkdir(parents=True, exist_ok=True)
        # Without blocking: a named pipe nobody reads would hold the open for ever.
        flags = os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NONBLOCK | os.O_NOFOLLOW
        fd = os.open(record, flags, 0o600)
        try:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                return False  # a pipe or a device is no record
            os.write(fd, (line + "\n").encode("utf-8"))
        finally:
            os.close(fd)
    except OSError:
        return False
    return True


def _record_lines() -> list[str]:
    """The record's lines; none when it is missing, unreadable, no regular file (a pipe
    is never waited on, a symbolic link never followed), larger than :data:`MAX_RECORD`,
    or not this user's alone (owned by another user, or writable by others: anyone could
    vouch for any file there)."""
    try:
        fd = os.open(record_path(), os.O_RDONLY | os.O_NONBLOCK | os.O_NOFOLLOW)
    except OSError:
        return []
    with os.fdopen(fd, "rb") as f:
        try:
            info = os.fstat(fd)
            if not stat.S_ISREG(info.st_mode) or info.st_size > MAX_RECORD:
                return []
            if info.st_uid != os.getuid() or info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
                return []
            return f.read(MAX_RECORD + 1).decode("utf-8").splitlines()
        except (OSError, UnicodeDecodeError):
            return []


def trained_here(actor: bytes) -> bool:
    """Whether this installation's ``marops train`` wrote a file of exactly these bytes."""
    digest = sha256_bytes(actor)
    for line in _record_lines():
        try:
            if json.loads(line).get("sha256") == digest:
                return True
        except (ValueError, AttributeError):
            continue  # a torn or foreign line never grants trust
    return False
