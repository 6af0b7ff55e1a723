"""The actors this installation trained: the SHA-256 of every TorchScript file ``marops
train`` wrote, one JSON line each, in ``$XDG_DATA_HOME/marops/trained-actors.jsonl``
(default ``~/.local/share/marops``). Such a file runs only code this installation wrote,
so it loads without ``--trust-actor`` (docs/method.md §6, "Trust model of actor files").

The record is only appended to (one short line per write, with ``O_APPEND``), so runs
training at once never lose each other's lines and no temporary is needed. A record
that cannot be written is skipped: the actor then needs its weights file or the flag.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import os
from pathlib import Path

RECORD = "trained-actors.jsonl"


def record_path() -> Path:
    """``$XDG_DATA_HOME/marops/trained-actors.jsonl`` (``~/.local/share`` by default)."""
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base) / "marops" / RECORD


def sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def record_trained(actor: bytes, path: str | Path) -> bool:
    """Note that this installation wrote the TorchScript file ``actor`` (its bytes) to
    ``path``; False when the record could not be written."""
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
        fd = os.open(record, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o600)
        try:
            os.write(fd, (line + "\n").encode("utf-8"))
        finally:
            os.close(fd)
    except OSError:
        return False
    return True


def trained_here(actor: bytes) -> bool:
    """Whether this installation's ``marops train`` wrote a file of exactly these bytes."""
    digest = sha256_bytes(actor)
    try:
        lines = record_path().read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError):
        return False
    for line in lines:
        try:
            if json.loads(line).get("sha256") == digest:
                return True
        except (ValueError, AttributeError):
            continue  # a torn or foreign line never grants trust
    return False
