"""Outputs complete or absent (docs/outputs.md): write to temporaries, rename at the end."""

from __future__ import annotations

import json
import os
import signal
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import Any

from ..errors import InputError, RunError

_REPLACE_FOREIGN: ContextVar[bool] = ContextVar("replace_foreign", default=False)


@contextmanager
def replacing_foreign_files(allowed: bool) -> Iterator[None]:
    """Within: outputs may replace existing files marops did not write (``--force``)."""
    token = _REPLACE_FOREIGN.set(allowed)
    try:
        yield
    finally:
        _REPLACE_FOREIGN.reset(token)


def allow_replacing_foreign(allowed: bool) -> None:
    """For the rest of this command: may outputs replace files marops did not write?"""
    _REPLACE_FOREIGN.set(allowed)


def written_by_marops(path: Path) -> bool:
    """An existing file is ours: Parquet with ``marops`` metadata, JSON or GeoJSON with a
    marops ``meta``/``marops`` member, or a figure, summary or journal we name."""
    suffix = path.suffix.lower()
    try:
        if suffix == ".parquet":
            import pyarrow.parquet as pq

            meta = pq.read_schema(path).metadata or {}
            return b"marops" in meta
        if suffix in (".json", ".geojson"):
            doc = json.loads(path.read_text(encoding="utf-8"))
            if not isinstance(doc, dict):
                return False
            head = doc.get("meta") or doc.get("marops") or {}
            return (
                isinstance(head, dict)
                and head.get("package") == "marops"
                or ("depots" in doc and "frame" in doc)
                or str(doc.get("format", "")).startswith("marops-")  # an actor's sidecar
            )
    except (OSError, ValueError):
        return False
    # figures, summaries, journals and actor files: named by the command, so ours
    return suffix in (".png", ".csv", ".md", ".jsonl", ".pt", ".safetensors", ".ckpt")


def check_replaceable(paths: list[Path]) -> None:
    """Refuse to replace a file marops did not write (unless ``--force``): every output
    is checked here when written, and a long command checks its outputs before any work
    too, so it cannot fail at its last step."""
    for final in paths:
        if final.is_file() and not _REPLACE_FOREIGN.get() and not written_by_marops(final):
            raise InputError(
                "exists and was not written by marops; pass --force to replace it", file=final
            )


class OutputSet:
    """A group of files written together: all of them appear, or none does.

    ``path_for(final)`` hands out a temporary path in the final file's folder;
    :meth:`commit` renames every temporary into place.
    """

    def __init__(self) -> None:
        self._pending: list[tuple[Path, Path]] = []

    def path_for(self, final: str | Path) -> Path:
        final = Path(final)
        check_replaceable([final])
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
        # Ctrl-C or SIGTERM waits until every file of the set is in place (the renames
        # take microseconds), so a stopped run never leaves half a set.
        stop = {signal.SIGINT, signal.SIGTERM}
        blocked = hasattr(signal, "pthread_sigmask")
        if blocked:
            old = signal.pthread_sigmask(signal.SIG_BLOCK, stop)
        try:
            for tmp, final in self._pending:
                os.chmod(tmp, mode)
                os.replace(tmp, final)
            self._pending.clear()
        finally:
            if blocked:
                signal.pthread_sigmask(signal.SIG_SETMASK, old)

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


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the program runs so temporaries are removed on the way out."""


@contextmanager
def folder_lock(folder: str | Path) -> Iterator[None]:
    """Hold ``folder`` for this run: a second run into it stops with a clear message
    instead of redoing the work; temporaries a killed run left there are removed."""
    import fcntl

    folder = Path(folder)
    created = not folder.exists()
    folder.mkdir(parents=True, exist_ok=True)
    lock = folder / ".marops.lock"
    fh = open(lock, "a+")  # noqa: SIM115 (held for the whole run)
    try:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            fh.seek(0)
            holder = fh.read().strip() or "another process"
            raise RunError(
                f"{folder}: another marops run ({holder}) is writing here; wait for it to "
                "finish or choose another --out"
            ) from None
        fh.seek(0)
        fh.truncate()
        fh.write(f"pid {os.getpid()}")
        fh.flush()
        remove_stale_temporaries(folder)
        yield
    finally:
        lock.unlink(missing_ok=True)
        fh.close()
        if created and not any(folder.iterdir()):  # a failed run leaves no empty folder
            folder.rmdir()


def remove_stale_temporaries(folder: Path) -> int:
    """Remove ``.NAME.XXXXXXXX.tmp`` files that a killed run left under ``folder``."""
    n = 0
    for tmp in folder.rglob(".*.tmp"):
        if tmp.is_file():
            tmp.unlink(missing_ok=True)
            n += 1
    return n
