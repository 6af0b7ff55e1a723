"""Outputs complete or absent (docs/outputs.md): write to temporaries, rename at the end."""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from ..errors import RunError


class OutputSet:
    """A group of files written together: all of them appear, or none does.

    ``path_for(final)`` hands out a temporary path in the final file's folder;
    :meth:`commit` renames every temporary into place.
    """

    def __init__(self) -> None:
        self._pending: list[tuple[Path, Path]] = []

    def path_for(self, final: str | Path) -> Path:
        final = Path(final)
        final.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{final.name}.", suffix=".tmp", dir=final.parent)
        os.close(fd)
        self._pending.append((Path(tmp), final))
        return Path(tmp)

    def write_bytes(self, final: str | Path, data: bytes) -> None:
        self.path_for(final).write_bytes(data)

    def write_json(self, final: str | Path, doc: Any) -> None:
        self.write_bytes(final, dumps_json(doc).encode("utf-8"))

    def write_with(self, final: str | Path, writer: Callable[[Path], None]) -> None:
        writer(self.path_for(final))

    def commit(self) -> None:
        mode = 0o666 & ~_umask()  # mkstemp makes 0600; outputs are shared like any file
        for tmp, final in self._pending:
            os.chmod(tmp, mode)
            os.replace(tmp, final)
        self._pending.clear()

    def discard(self) -> None:
        for tmp, _ in self._pending:
            tmp.unlink(missing_ok=True)
        self._pending.clear()


@contextmanager
def output_set() -> Iterator[OutputSet]:
    """Context manager: commit on success, remove every temporary on any error."""
    out = OutputSet()
    try:
        yield out
    except BaseException:
        out.discard()
        raise
    try:
        out.commit()
    except OSError as exc:
        out.discard()
        raise RunError(f"could not write outputs: {exc}") from exc


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def dumps_json(doc: Any) -> str:
    """Stable JSON text: sorted keys would reorder tables, so keep insertion order."""
    return json.dumps(doc, indent=2, ensure_ascii=False, allow_nan=False) + "\n"
