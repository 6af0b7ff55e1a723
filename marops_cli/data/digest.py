"""A file's SHA-256: how marops identifies every file it reads or writes (inputs,
depots, actors, its own outputs). Its own module, so that naming a file's identity
loads none of the data reader's libraries."""

from __future__ import annotations

import hashlib
from pathlib import Path


def sha256_file(path: str | Path, chunk: int = 4 << 20) -> str:
    """SHA-256 of a file, read in chunks so a large export never sits in memory whole."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(chunk):
            h.update(block)
    return h.hexdigest()
