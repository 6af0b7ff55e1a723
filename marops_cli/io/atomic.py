"""Outputs complete or absent (docs/outputs.md): write to temporaries, rename at the end."""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import stat
import tempfile
import threading
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any

from ..data.digest import sha256_file
from ..errors import InputError, RunError, option
from .ownership import (
    JOURNAL,
    TMP_MARK,
    cannot_write,
    check_replaceable,
    folder_held,
    journal_update,
    needs_journal,
)


class OutputSet:
    """A group of files written together: all of them appear, or none does.

    ``path_for(final)`` hands out a temporary path in the final file's folder;
    :meth:`commit` renames every temporary into place.
    """

    def __init__(self) -> None:
        self._pending: list[tuple[Path, Path]] = []
        self._journal: set[Path] = set()
        """Files journaled whatever their suffix (:meth:`path_for`)."""

    def path_for(self, final: str | Path, journal: bool = False) -> Path:
        """A temporary for ``final``; ``journal``: ``final`` goes into its folder's
        journal even where its suffix is one that carries metadata (a Parquet file
        without marops metadata, such as ``synth``'s data)."""
        final = Path(final)
        check_replaceable([final], journal)
        try:
            final.parent.mkdir(parents=True, exist_ok=True)
            _clean_once(final.parent)
            fd, tmp = tempfile.mkstemp(
                prefix=f".{final.name}.{TMP_MARK}", suffix=".tmp", dir=final.parent
            )
        except OSError as exc:
            raise cannot_write(final, exc) from None
        os.close(fd)
        self._pending.append((Path(tmp), final))
        if journal:
            self._journal.add(final)
        return Path(tmp)

    def write_bytes(self, final: str | Path, data: bytes) -> None:
        self.write_with(final, lambda tmp: tmp.write_bytes(data))

    def write_json(self, final: str | Path, doc: Any) -> None:
        self.write_bytes(final, dumps_json(doc).encode("utf-8", "backslashreplace"))

    def write_with(
        self, final: str | Path, writer: Callable[[Path], object], journal: bool = False
    ) -> None:
        tmp = self.path_for(final, journal)
        try:
            writer(tmp)
        except OSError as exc:
            if exc.errno is None:
                raise
            raise cannot_write(Path(final), exc) from None

    def commit(self) -> None:
        mode = 0o666 & ~_umask()  # mkstemp makes 0600; outputs are shared like any file
        # Files without marops metadata go into their folder's journal, renamed into
        # place with them (docs/outputs.md).
        journaled: dict[Path, dict[str, str]] = {}
        for tmp, final in self._pending:
            if needs_journal(final) or final in self._journal:
                journaled.setdefault(final.parent, {})[final.name] = sha256_file(tmp)
        with ExitStack() as held:
            for folder in journaled:
                held.enter_context(folder_held(folder))
            journals = []
            for folder, names in journaled.items():
                try:
                    journals.append((journal_update(folder, names), folder / JOURNAL))
                except OSError as exc:
                    self._pending.extend(journals)  # removed by discard()
                    raise cannot_write(folder / JOURNAL, exc) from None
            self._pending.extend(journals)
            self._rename_all(mode, first=len(self._pending) - len(journals))

    def _rename_all(self, mode: int, first: int) -> None:
        """Journals first (they list old and new content), then the files."""
        order = self._pending[first:] + self._pending[:first]
        # Ctrl-C or SIGTERM waits until every file of the set is in place (the renames
        # take microseconds), so a stopped run never leaves half a set.
        stop = {signal.SIGINT, signal.SIGTERM}
        blocked = hasattr(signal, "pthread_sigmask")
        if blocked:
            old = signal.pthread_sigmask(signal.SIG_BLOCK, stop)
        try:
            for tmp, final in order:
                try:
                    os.chmod(tmp, mode)
                    os.replace(tmp, final)
                except OSError as exc:
                    raise cannot_write(final, exc) from None
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
    except BaseException:
        out.discard()
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def dumps_json(doc: Any) -> str:
    """Stable JSON text: sorted keys would reorder tables, so keep insertion order."""
    return json.dumps(doc, indent=2, ensure_ascii=False, allow_nan=False) + "\n"


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the program runs so temporaries are removed on the way out."""


TERM_RECEIVED = threading.Event()
"""Set when SIGTERM arrived: an error it caused on its way (raised inside a library's
module import, it can surface as an ``AttributeError`` of that module) ends the run as
the termination it is."""


LOCK = ".marops.lock"


@contextmanager
def folder_lock(folder: str | Path) -> Iterator[None]:
    """Hold ``folder`` for this run: a second run into it stops with a clear message
    instead of redoing the work; temporaries a killed run left there are removed.

    The lock is an OS lock (``flock``) on ``.marops.lock``, held while the file is
    open: only its holder ever removes that file, and only while holding it, so a
    refused run cannot break the lock of the run that holds it.
    """
    folder = Path(folder)
    created = not folder.exists()
    folder.mkdir(parents=True, exist_ok=True)
    lock = folder / LOCK
    fh = _take(folder, lock)
    root = folder.resolve()
    try:
        with _GUARD:
            _HELD[root] = os.getpid()
        _clean_once(folder)
        yield
    finally:
        with _GUARD:
            _HELD.pop(root, None)
            _CLEANED.difference_update({f for f in _CLEANED if f == root or root in f.parents})
        empty = created and not any(p.name != LOCK for p in folder.iterdir())
        lock.unlink(missing_ok=True)  # still holding it: the next run takes a fresh one
        fh.close()
        if empty:  # a failed run leaves no empty folder
            with contextlib.suppress(OSError):  # another run created its lock meanwhile
                folder.rmdir()


def _take(folder: Path, lock: Path) -> Any:
    """The open, locked lock file, or a :class:`RunError` naming the holder."""
    import fcntl

    while True:
        fh = _open_lock(lock)
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = _held(fh)
            fh.close()
            if holder and not _OURS.fullmatch(holder):
                raise _foreign(lock) from None
            raise RunError(
                f"{folder}: another marops run ({holder or 'another process'}) is writing "
                "here; wait for it to finish or choose another --out"
            ) from None
        # Empty, it is a run's that has not written its pid yet, or a killed one's.
        if (held := _held(fh)) and not _OURS.fullmatch(held):
            fh.close()  # a file of the same name marops did not write: left as it is
            raise _foreign(lock)
        # The holder removes the file as it ends: a lock taken on a file already
        # removed holds nothing, so take the one now at that name.
        try:
            same = os.path.samestat(os.fstat(fh.fileno()), os.stat(lock))
        except FileNotFoundError:
            same = False
        if same:
            break
        fh.close()
    fh.seek(0)
    fh.truncate()
    fh.write(f"pid {os.getpid()}".encode())
    fh.flush()
    return fh


# What a marops lock holds: the holder's process id.
_OURS = re.compile(r"pid \d+")


def _held(fh: Any) -> str:
    """What a lock file holds, as text (bytes that are no UTF-8 replaced: no marops
    lock holds them)."""
    fh.seek(0)
    return fh.read(256).decode("utf-8", errors="replace").strip()


def _open_lock(lock: Path) -> Any:
    """The lock file opened for reading and appending, created if absent; never through
    a link, and never anything but a plain file (it is truncated and removed later)."""
    try:
        fd = os.open(lock, os.O_RDWR | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW, 0o666)
    except OSError as exc:
        if lock.is_symlink() or (lock.exists() and not lock.is_file()):
            raise _foreign(lock) from None
        raise RunError(f"{lock}: cannot open the folder's lock ({exc.strerror})") from None
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise _foreign(lock)
    return os.fdopen(fd, "a+b")


def _foreign(lock: Path) -> InputError:
    return InputError(
        f"{lock}: a file of this name that marops did not write is in the way of the "
        f"folder's lock; marops leaves it as it is: move it or choose another {option('out')}"
    )


# Folders under a lock this process holds, and those already cleaned of stale
# temporaries this run: a folder is cleaned before this run's first temporary there,
# so only a killed run's can go.
_GUARD = threading.Lock()
_HELD: dict[Path, int] = {}
_CLEANED: set[Path] = set()


def _clean_once(folder: Path) -> None:
    """Remove a killed run's temporaries from ``folder`` the first time this run writes
    there, when a lock this process holds covers it (no other run writes there)."""
    here = folder.resolve()
    with _GUARD:
        if here in _CLEANED:
            return
        pid = os.getpid()
        if not any(p == pid and (r == here or r in here.parents) for r, p in _HELD.items()):
            return
        _CLEANED.add(here)
        remove_stale_temporaries(here)


_STALE = re.compile(r"^\..+\." + TMP_MARK + r"[a-z0-9_]{8}\.tmp$")


def remove_stale_temporaries(folder: Path) -> int:
    """Remove the temporaries (``.NAME.marops-XXXXXXXX.tmp``) a killed run left in
    ``folder`` itself: not below it, and nothing named otherwise."""
    n = 0
    for tmp in folder.iterdir():
        if _STALE.match(tmp.name) and tmp.is_file() and not tmp.is_symlink():
            tmp.unlink(missing_ok=True)
            n += 1
    return n
