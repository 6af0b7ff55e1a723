"""Outputs complete or absent (docs/outputs.md): write to temporaries, rename at the end."""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import secrets
import stat
import threading
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
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
    missing_folders,
    needs_journal,
    remove_empty_folders,
    temporary_name,
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
        self.placed: dict[Path, os.stat_result] = {}
        """Each file committed, with what it was as it was renamed into place (a run
        checks later that a day's files are still the ones it wrote)."""
        self._made: list[Path] = []
        """Folders made for the files, removed again if empty when the set is discarded."""

    def path_for(self, final: str | Path, journal: bool = False) -> Path:
        """A temporary for ``final``; ``journal``: ``final`` goes into its folder's
        journal even where its suffix is one that carries metadata (a Parquet file
        without marops metadata, such as ``synth``'s data)."""
        final = Path(final)
        check_replaceable([final], journal)
        self._made += missing_folders(final)
        try:
            final.parent.mkdir(parents=True, exist_ok=True)
            with _signals_held():  # made and listed at once: discard() removes what was made
                tmp = temporary(final.parent, final.name)
                self._pending.append((tmp, final))
        except OSError as exc:
            raise cannot_write(final, exc) from None
        if journal:
            self._journal.add(final)
        return tmp

    def write_bytes(self, final: str | Path, data: bytes, journal: bool = False) -> None:
        self.write_with(final, lambda tmp: tmp.write_bytes(data), journal)

    def write_json(self, final: str | Path, doc: Any, journal: bool = False) -> None:
        """``doc`` as JSON; ``journal``: recorded in the folder's journal too, so that an
        edit makes it the user's (a depots or hubs file, which analysts edit)."""
        self.write_bytes(final, dumps_json(doc).encode("utf-8", "backslashreplace"), journal)

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
            journals: list[tuple[Path, Path]] = []
            for folder, names in journaled.items():
                try:
                    with _signals_held():
                        tmp = temporary(folder, JOURNAL)
                        journals.append((tmp, folder / JOURNAL))
                    journal_update(folder, names, tmp)
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
        with _signals_held():
            for tmp, final in order:
                try:
                    os.chmod(tmp, mode)
                    placed = os.lstat(tmp)
                    os.replace(tmp, final)
                except OSError as exc:
                    raise cannot_write(final, exc) from None
                self.placed[final] = placed
                settled(tmp)
            self._pending.clear()

    def discard(self) -> None:
        for tmp, _ in self._pending:
            tmp.unlink(missing_ok=True)
            settled(tmp)
        self._pending.clear()
        remove_empty_folders(self._made)
        self._made.clear()


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


def _signals_held() -> contextlib.AbstractContextManager[None]:
    """Ctrl-C and SIGTERM held back within (:func:`~marops_cli.workers.pool.signals_held`)."""
    from ..workers.pool import signals_held  # deferred: not loaded for --help

    return signals_held()


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
    """Hold ``folder`` for this run: a second run into it, or into a folder inside it or
    above it, stops with a clear message instead of redoing or mixing the work; the
    temporaries a killed run recorded in the lock are removed.

    The lock is an OS lock (``flock``) on ``.marops.lock``, held while the file is
    open: only its holder ever removes that file, and only while holding it, so a
    refused run cannot break the lock of the run that holds it. The file holds the
    holder's pid and, on the lines after it, the temporaries the run is making below
    the folder (``tmp NAME`` before one is made, ``done NAME`` once it is renamed or
    removed; the lines go when none is left): the only files the next run removes.
    """
    folder = Path(folder)
    if os.path.lexists(folder) and not folder.is_dir():  # a file of its name
        raise InputError(
            f"is a file where marops makes a folder; move it or choose another {option('out')}",
            file=folder,
        )
    made = missing_folders(folder / LOCK)  # the folder and those above it, deepest first
    folder.mkdir(parents=True, exist_ok=True)
    lock = folder / LOCK
    fh = _take(folder, lock)
    root = folder.resolve()
    try:
        with _GUARD:
            _HELD[root] = _Hold(os.getpid(), fh, len(f"pid {os.getpid()}"))
        _refuse_nested(folder, root)
        yield
    finally:
        with _GUARD:
            _HELD.pop(root, None)
        empty = bool(made) and not any(p.name != LOCK for p in folder.iterdir())
        lock.unlink(missing_ok=True)  # still holding it: the next run takes a fresh one
        fh.close()
        if empty:  # a failed run leaves no empty folder, nor the empty ones above it
            remove_empty_folders(made)  # one with another run's lock or files stays


def _take(folder: Path, lock: Path) -> Any:
    """The open, locked lock file, or a :class:`RunError` naming the holder; the
    temporaries a killed holder recorded in it are removed."""
    import fcntl

    while True:
        fh = _open_lock(lock)
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            content = _content(fh)
            fh.close()
            if _recorded(content) is None:
                raise _foreign(lock) from None
            raise RunError(
                f"{folder}: another marops run ({_holder_of(content)}) is writing "
                "here; wait for it to finish or choose another --out"
            ) from None
        # Empty, it is a run's that has not written its pid yet, or a killed one's.
        left = _recorded(_content(fh))
        if left is None:
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
    _remove_recorded(folder, left)
    fh.seek(0)
    fh.truncate()
    fh.write(f"pid {os.getpid()}".encode())
    fh.flush()
    return fh


# What a marops lock holds: the holder's process id, then the temporaries it recorded.
_OURS = re.compile(r"pid \d+")
_CHARS = "abcdefghijklmnopqrstuvwxyz0123456789_"
_TMP_NAME = r"\.[^/\n]+\." + TMP_MARK + r"[a-z0-9_]{8}\.tmp"
_RECORD = re.compile(r"(?P<what>tmp|done) (?P<rel>(?:[^/\n]+/)*" + _TMP_NAME + ")")
_LOCK_MAX = 1 << 20
"""A lock lists the temporaries of one output set at most (a few lines): a larger file
is none of marops's."""


def _content(fh: Any) -> bytes:
    """What a lock file holds (up to :data:`_LOCK_MAX` and a byte)."""
    fh.seek(0)
    data: bytes = fh.read(_LOCK_MAX + 1)
    return data


def _recorded(content: bytes) -> list[str] | None:
    """The temporaries a marops lock lists as being made (relative to its folder), in
    order; None for a file marops did not write (anything but ``pid N`` and records of
    temporaries, or nothing)."""
    if len(content) > _LOCK_MAX:
        return None
    text = content.decode("utf-8", errors="surrogateescape").strip()
    if not text:
        return []
    first, *records = text.split("\n")
    if not _OURS.fullmatch(first):
        return None
    made: dict[str, None] = {}
    for line in records:
        m = _RECORD.fullmatch(line)
        if m is None or any(part in (".", "..") for part in m["rel"].split("/")):
            return None
        if m["what"] == "tmp":
            made[m["rel"]] = None
        else:
            made.pop(m["rel"], None)
    return list(made)


def _holder_of(content: bytes) -> str:
    """The holder a lock names (``pid N``), as text."""
    first = content[:256].decode("utf-8", errors="replace").strip().split("\n")[0]
    return first or "another process"


def _remove_recorded(folder: Path, names: list[str]) -> int:
    """Remove the temporaries a killed run recorded in ``folder``'s lock: each only when
    it is still a regular file of this user's at that place, reached through no link."""
    n = 0
    uid = os.getuid()
    for rel in names:
        *parts, name = rel.split("/")
        here = folder
        try:
            for part in parts:
                here = here / part
                if not stat.S_ISDIR(os.lstat(here).st_mode):  # a link is no folder here
                    raise NotADirectoryError(here)
            st = os.lstat(here / name)
            if stat.S_ISREG(st.st_mode) and st.st_uid == uid:
                os.unlink(here / name)
                n += 1
        except OSError:
            continue
    return n


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


def check_free(folder: str | Path) -> None:
    """Before any work: refuse ``folder`` while another run holds it (exit 1, as
    :func:`folder_lock` would) or a folder above or inside it (exit 2), so that a run
    refused prints that line alone. :func:`folder_lock` checks again as it takes it."""
    folder = Path(folder)
    if not folder.is_dir():
        _refuse_nested(folder, _existing(folder.absolute()), made=False)
        return
    holder = _busy(folder / LOCK)
    if holder is not None and folder.resolve() not in _mine():
        raise RunError(
            f"{folder}: another marops run ({holder}) is writing here; wait for it to "
            "finish or choose another --out"
        )
    _refuse_nested(folder, folder.resolve())


def check_unheld(path: str | Path) -> None:
    """Before any work: refuse an output file (``segment``'s, ``synth``'s, ``train``'s,
    which take no folder lock) whose folder, or a folder above it, another run holds
    (docs/outputs.md, "The folder lock"): it would land among that run's files, or
    replace one of them as the run writes it."""
    path = Path(path)
    _refuse_nested(path, _existing(path.absolute().parent), made=False)


def _existing(path: Path) -> Path:
    """The nearest of ``path`` and the folders above it that exists, resolved."""
    while not path.exists():
        path = path.parent
    return path.resolve()


def _mine() -> set[Path]:
    """The folders this process holds."""
    with _GUARD:
        return {r for r, h in _HELD.items() if h.pid == os.getpid()}


def _refuse_nested(folder: Path, root: Path, *, made: bool = True) -> None:
    """Refuse ``folder`` while another run holds a folder above it or inside it: the two
    would write into one tree, and a summary of one would claim the other's days
    (docs/outputs.md, "The folder lock"). ``root`` is ``folder`` resolved or, when it is
    not ``made`` yet, the nearest folder above it that is (nothing lies inside it yet).
    Folders this process holds (a city's and its hubs') are no other run's."""
    mine = _mine()
    for above in root.parents if made else [root, *root.parents]:
        holder = None if above in mine else _busy(above / LOCK)
        if holder is not None:
            raise InputError(
                f"another marops run ({holder}) is writing into this folder, which holds "
                f"{option('out')} {folder}; wait for it to finish or choose another "
                f"{option('out')}",
                file=_shown(above),
            )
    if not made:
        return
    for dirpath, _, names in os.walk(root):  # links are not followed
        here = Path(dirpath)
        if here == root or LOCK not in names or here in mine:
            continue
        holder = _busy(here / LOCK)
        if holder is not None:
            raise InputError(
                f"another marops run ({holder}) is writing into this folder, inside "
                f"{option('out')} {folder}; wait for it to finish or choose another "
                f"{option('out')}",
                file=folder / here.relative_to(root),
            )


def _busy(lock: Path) -> str | None:
    """The holder of ``lock`` (``pid N``) while a run holds it; None when no run does (no
    such file, a killed run's, or one that cannot be read). Tried with a shared lock,
    dropped at once, never with the holder's exclusive one."""
    import fcntl

    try:
        fd = os.open(lock, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except OSError:
        return None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return None
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError:
            return _holder_of(os.read(fd, 256))
        return None  # nobody holds it; closing drops this process's probe
    finally:
        os.close(fd)


def _shown(path: Path) -> Path:
    """``path`` as the user would write it: relative to the current folder when inside it."""
    try:
        return path.relative_to(Path.cwd().resolve())
    except ValueError:
        return path


@dataclass
class _Hold:
    """A folder lock this process holds: its open file, the length of its first line
    (``pid N``) and the temporaries it lists as being made."""

    pid: int
    fh: Any
    header: int
    making: set[str] = field(default_factory=set)


# Folders under a lock this process holds, and the temporaries recorded in them.
_GUARD = threading.Lock()
_HELD: dict[Path, _Hold] = {}
_RECORDS: dict[Path, tuple[_Hold, str]] = {}


def temporary(folder: Path, name: str) -> Path:
    """A new, empty temporary for ``name`` in ``folder`` (which exists):
    ``.NAME.marops-XXXXXXXX.tmp``, recorded in the lock this run holds over the folder
    before it is made, so that the next run removes it if this one is killed (and
    nothing that is merely named so). Call :func:`settled` once it is renamed or removed."""
    for _ in range(100):
        suffix = "".join(secrets.choice(_CHARS) for _ in range(8))
        tmp = folder / temporary_name(name, suffix)
        _record(tmp)
        try:
            fd = os.open(tmp, os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
        except FileExistsError:  # someone's file by that name: never ours to remove
            settled(tmp)
            continue
        except BaseException:
            settled(tmp)
            raise
        os.close(fd)
        return tmp
    raise FileExistsError(errno.EEXIST, "no free temporary name", str(folder))


def _record(tmp: Path) -> None:
    """List ``tmp`` in the lock of the innermost folder this process holds above it."""
    here = tmp.parent.resolve()
    with _GUARD:
        pid = os.getpid()
        roots = [r for r, h in _HELD.items() if h.pid == pid and (r == here or r in here.parents)]
        if not roots:
            return  # no lock of this run over it: nothing records it, nothing removes it
        root = max(roots, key=lambda r: len(r.parts))
        hold = _HELD[root]
        rel = (here / tmp.name).relative_to(root).as_posix()
        if "\n" in rel:
            return
        os.write(hold.fh.fileno(), b"\ntmp " + os.fsencode(rel))
        hold.making.add(rel)
        _RECORDS[tmp] = (hold, rel)


def settled(tmp: Path) -> None:
    """``tmp`` is renamed into place or removed: its record goes (the lock holds only
    ``pid N`` again once no temporary is being made)."""
    with _GUARD:
        found = _RECORDS.pop(tmp, None)
        if found is None:
            return
        hold, rel = found
        hold.making.discard(rel)
        if hold.fh.closed:
            return
        with contextlib.suppress(OSError):
            if hold.making:
                os.write(hold.fh.fileno(), b"\ndone " + os.fsencode(rel))
            else:
                os.ftruncate(hold.fh.fileno(), hold.header)
