"""Which files marops may replace (docs/outputs.md): its own, judged by provenance, never
a run's inputs, and only where it can write.

A file is marops's when the folder's journal ``.marops-files.json`` lists it with the
SHA-256 of what is there now; where the journal does not list it, when its content says
so (a Parquet file's ``marops`` metadata, a JSON document's marops ``meta``, a training
checkpoint's format). Files without metadata (CSV, PNG, Markdown, HTML, actors) go into
the journal, and so do the depots and hubs files, which analysts edit: a file edited
since is not marops's any more, whatever its metadata says. The name never decides.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import stat
import tempfile
import zipfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import Any

from ..data.digest import sha256_file
from ..data.jsonfile import MAX_SMALL_FILE, parse_json, read_small_text, read_text_at_most
from ..errors import InputError, RunError, option, switch

JOURNAL = ".marops-files.json"
JOURNAL_FORMAT = "marops-files/1"
TMP_MARK = "marops-"
"""Temporaries are ``.NAME.marops-XXXXXXXX.tmp``: nothing a user makes is named so."""
JOBS_IDENTITY = "_identity.json"
"""The file that marks an evaluation's jobs folder (``OUT/jobs``, evaluate/dataset.py):
no other output goes there or below it."""

_REPLACE_FOREIGN: ContextVar[bool] = ContextVar("replace_foreign", default=False)
_RUN_INPUTS: ContextVar[tuple[Path, ...]] = ContextVar("run_inputs", default=())
_STDIN_INPUT: ContextVar[tuple[int, int] | None] = ContextVar("stdin_input", default=None)
"""Standard input's device and inode when the run reads a regular file from it."""
_WITH_METADATA = (".parquet", ".json", ".geojson", ".ckpt")
_JOURNALS: ContextVar[dict[Path, dict[str, Any] | None] | None] = ContextVar(
    "journals", default=None
)
"""Within :func:`_journals_read_once`: each folder's journal as read, by folder."""


@contextmanager
def replacing_foreign_files(allowed: bool) -> Iterator[None]:
    """Within: one run; outputs may replace existing files marops did not write
    (``--force``), and the run's inputs are registered afresh."""
    token = _REPLACE_FOREIGN.set(allowed)
    inputs = _RUN_INPUTS.set(())
    stdin = _STDIN_INPUT.set(None)
    try:
        yield
    finally:
        _STDIN_INPUT.reset(stdin)
        _RUN_INPUTS.reset(inputs)
        _REPLACE_FOREIGN.reset(token)


def allow_replacing_foreign(allowed: bool) -> None:
    """For the rest of this command: may outputs replace files marops did not write?"""
    _REPLACE_FOREIGN.set(allowed)


def new_run() -> None:
    """A command starts: no inputs registered, no foreign file replaced."""
    _REPLACE_FOREIGN.set(False)
    _RUN_INPUTS.set(())
    _STDIN_INPUT.set(None)


def register_inputs(paths: Iterable[object]) -> None:
    """The files this run reads: no output of the run may replace one (see
    :func:`check_not_input`), whatever the names. Missing paths and tables in memory
    (anything not a path) are skipped."""
    known = list(_RUN_INPUTS.get())
    for p in paths:
        if isinstance(p, str | os.PathLike) and Path(p).exists() and Path(p) not in known:
            known.append(Path(p))
    _RUN_INPUTS.set(tuple(known))


def register_stdin() -> None:
    """Standard input, when it is a regular file (``marops CMD - < FILE``), is an input
    of the run too: its name is unknown, so it is told by its device and inode."""
    try:
        st = os.fstat(0)
    except OSError:  # closed
        return
    if stat.S_ISREG(st.st_mode):
        _STDIN_INPUT.set((st.st_dev, st.st_ino))


def check_not_input(final: Path) -> None:
    """Refuse an output that is one of the run's inputs: the same resolved path or the
    same file (an inode reached through a symlink, a hard link or ``..``, or the file
    standard input reads)."""
    try:
        target = Path(final).resolve()
    except RuntimeError:  # a symlink loop (Python 3.11 raises this, not OSError)
        raise InputError("cannot write (a loop of symbolic links)", file=final) from None
    for inp in _RUN_INPUTS.get():
        same = inp.resolve() == target
        if not same and final.exists():
            with contextlib.suppress(OSError):
                same = os.path.samefile(inp, final)
        if same:
            raise InputError(
                f"is an input of this run ({inp}); choose another {option('out')}", file=final
            )
    stdin = _STDIN_INPUT.get()
    if stdin is not None:
        try:
            st = os.stat(final)
        except OSError:  # absent: no input
            return
        if (st.st_dev, st.st_ino) == stdin:
            raise InputError(
                f"is an input of this run (standard input); choose another {option('out')}",
                file=final,
            )


def written_by_marops(path: Path) -> bool:
    """An existing file is marops's: one the folder's journal lists with the content it
    has now; of those the journal does not list, Parquet with ``marops`` metadata, JSON
    or GeoJSON with a marops ``meta``/``marops`` member (or an actor's sidecar), a
    training checkpoint. A listed file whose content changed (a depots file edited by
    hand) is not marops's, whatever its metadata says."""
    suffix = path.suffix.lower()
    try:
        listed = _journal(path.parent).get(path.name)
        if listed:
            return sha256_file(path) in listed
        if suffix == ".parquet":
            from ..data.arrow import read_parquet_schema

            ours = b"marops" in (read_parquet_schema(path).metadata or {})
        elif suffix in (".json", ".geojson"):
            ours = _json_is_ours(path)
        else:
            ours = suffix == ".ckpt" and _checkpoint_is_ours(path)
        return ours
    except (OSError, ValueError, zipfile.BadZipFile, InputError):
        return False


def remove_ours(paths: Iterable[Path]) -> None:
    """Remove those of ``paths`` that are files marops wrote (:func:`written_by_marops`),
    an earlier run's outputs this run does not write again; a link, any other file and
    the run's inputs (:func:`check_not_input`) stay."""
    with _journals_read_once():
        for path in paths:
            if path.is_symlink() or not path.is_file():
                continue
            try:
                check_not_input(path)
            except InputError:
                continue
            if written_by_marops(path):
                path.unlink()


def _json_is_ours(path: Path) -> bool:
    if path.stat().st_size > MAX_SMALL_FILE:
        # A busy day's stops.json: judged by its first member alone, never loaded whole
        # into memory.
        from .routejson import route_json_meta

        try:
            head = route_json_meta(path, "marops" if path.suffix.lower() == ".geojson" else "meta")
        except KeyError:
            return False
        return isinstance(head, dict) and head.get("package") == "marops"
    doc = parse_json(read_text_at_most(path, "JSON file", MAX_SMALL_FILE))
    if not isinstance(doc, dict):
        return False
    head = doc.get("meta") or doc.get("marops") or {}
    # A depots file counts as marops' own only with marops' "meta": one written by hand
    # (docs/outputs.md allows it) has the same "depots" and "frame" keys.
    return (
        isinstance(head, dict)
        and head.get("package") == "marops"
        or str(doc.get("format", "")).startswith("marops-")  # an actor's sidecar
    )


def _checkpoint_is_ours(path: Path) -> bool:
    """A training checkpoint names its format (``marops-train-ckpt/N``) in the state it
    holds: read from the archive's pickle as bytes, never unpickled; the landing actor's
    checkpoint is JSON (``marops-landing-ckpt/N``)."""
    if not zipfile.is_zipfile(path):
        return _json_is_ours(path)
    with zipfile.ZipFile(path) as archive:
        pickles = [n for n in archive.namelist() if n.endswith("/data.pkl")]
        if not pickles:
            return False
        # The format is the state's first key: the pickle's first bytes hold it. Only
        # those are read, so a foreign archive that inflates to gigabytes stays shut.
        with archive.open(pickles[0]) as fh:
            return b"marops-train-ckpt/" in fh.read(1 << 16)


def check_replaceable(paths: Iterable[Path], journal: bool = False) -> None:
    """Refuse an output that is an input of the run, or an existing file marops did not
    write (unless ``--force``); ``journal``: the outputs go into their folder's journal
    whatever their suffix (a Parquet file without marops metadata: ``synth``'s)."""
    with _journals_read_once():
        for final in paths:
            _check_replaceable(Path(final), journal)


def _check_replaceable(final: Path, journal: bool) -> None:
    """:func:`check_replaceable` of one output."""
    try:
        check_not_input(final)
        if final.is_dir():  # renaming a file onto it would fail after the work
            raise InputError("is a folder, expected a file name", file=final)
        if _special(final):  # a pipe or a device is no output, --force or not
            raise InputError(
                "is a pipe, a socket or a device, not a file marops may replace",
                file=final,
            )
        # A symbolic link is the user's, whatever it leads to: marops writes none (and
        # reading one to a pipe to find out whose its target is could block).
        foreign = (
            not _REPLACE_FOREIGN.get()
            and os.path.lexists(final)
            and (final.is_symlink() or not final.is_file() or not written_by_marops(final))
        )
    except OSError as exc:  # a name too long, a loop of symbolic links
        raise InputError(f"cannot write ({_reason(exc)})", file=final) from None
    if foreign:
        raise InputError(
            f"exists and was not written by marops; pass {switch('force')} to replace it",
            file=final,
        )
    if (journal or needs_journal(final)) and not _REPLACE_FOREIGN.get():
        _check_journal(final.parent)


def _special(path: Path) -> bool:
    """Whether ``path`` itself (not a link's target) is a pipe, a socket or a device."""
    try:
        mode = os.lstat(path).st_mode
    except OSError:  # absent, or below a file: judged where the folder is made
        return False
    return not (stat.S_ISREG(mode) or stat.S_ISDIR(mode) or stat.S_ISLNK(mode))


def _check_journal(folder: Path) -> None:
    """Refuse to write a file the journal must list into ``folder`` when a file by the
    journal's name is there that is no journal of marops (docs/outputs.md): rewriting
    it would replace a file marops did not write."""
    journal = folder / JOURNAL
    if os.path.lexists(journal) and _journal_doc(folder) is None:
        raise InputError(
            f"exists and is not the journal marops keeps under this name (format "
            f"{JOURNAL_FORMAT}, docs/outputs.md); move it away or choose another {option('out')}",
            file=journal,
        )


def refuse_links_below(root: Path, paths: Iterable[Path]) -> None:
    """Refuse an output whose folder below ``root`` (a day's or a hub's) is a link: a
    run writes those folders' files itself, never through a link into another folder
    (another run's days), ``--force`` or not."""
    root = Path(root).absolute()
    for p in paths:
        folder = Path(p).absolute().parent
        while folder != root and root in folder.parents:
            if folder.is_symlink():
                raise InputError(
                    f"is a link; the folders of days and hubs below {option('out')} are "
                    f"marops's own: remove it or choose another {option('out')}",
                    file=folder,
                )
            folder = folder.parent


def missing_folders(final: Path) -> list[Path]:
    """The folders above ``final`` that do not exist yet, deepest first."""
    missing = []
    folder = Path(final).absolute().parent
    while not folder.exists() and folder != folder.parent:
        missing.append(folder)
        folder = folder.parent
    return missing


def remove_empty_folders(folders: Iterable[Path]) -> None:
    """Remove those of ``folders`` that are empty, deepest first (a run's own, made for
    outputs it did not write); one that holds something stays, and so do those above it."""
    for folder in sorted(folders, key=lambda p: len(Path(p).absolute().parts), reverse=True):
        with contextlib.suppress(OSError):
            folder.rmdir()


def temporary_name(name: str, tag: str) -> str:
    """The name of a temporary for the output ``name``: ``.NAME.marops-TAG.tmp``."""
    return f".{name}.{TMP_MARK}{tag}.tmp"


def check_outputs(paths: Iterable[Path], journal: bool = False) -> None:
    """Before any work: each output may be replaced (above; ``journal`` as there) and
    its folder written, found out by creating and removing a temporary there (or, for a
    folder still to be made, by the nearest existing one, whose file system must take
    the names of the folders to make there)."""
    from ..workers.pool import signals_held  # deferred: not loaded for --help

    with _journals_read_once():  # the probes below write no journal
        for final in paths:
            final = Path(final)
            check_outside_jobs(final)
            check_replaceable([final], journal)
            to_make = missing_folders(final)
            folder = (to_make[-1] if to_make else final.absolute()).parent
            if not folder.is_dir():
                raise InputError(f"cannot be created: {folder} is a file", file=final)
            _names_fit(final, folder, [f.name for f in to_make])
            try:
                with signals_held():  # a Ctrl-C meanwhile leaves no probe behind
                    fd, probe = tempfile.mkstemp(
                        prefix=f".{final.name}.{TMP_MARK}", suffix=".tmp", dir=folder
                    )
                    os.close(fd)
                    os.unlink(probe)
            except OSError as exc:  # found before the work: bad usage, exit 2
                raise InputError(f"cannot write ({_reason(exc)})", file=final) from None


def check_outside_jobs(path: Path) -> None:
    """``path`` (an output, or an output folder) is no evaluation's jobs folder (one
    holding :data:`JOBS_IDENTITY`) and lies in none: written there it would lie among
    that evaluation's jobs, which it then refuses to resume or summarise. One line naming
    ``path`` and the jobs folder, before any work."""
    here = Path(path).absolute()
    for folder in (here, *here.parents):
        try:
            marked = (folder / JOBS_IDENTITY).is_file()
        except OSError:  # a name too long for the system: no folder, no jobs (said later)
            marked = False
        if marked:
            raise InputError(
                f"lies in the jobs folder of the evaluation in {folder.parent}, which would "
                f"then hold files that are not its jobs; choose another {option('out')}",
                file=path,
            )


def _names_fit(final: Path, folder: Path, to_make: list[str]) -> None:
    """The folders ``to_make`` under ``folder`` (and the whole path of ``final``'s
    temporary, ``.NAME.marops-XXXXXXXX.tmp`` beside it, longer than ``final``) fit the
    file system's limits: a name too long would fail only when the folders are made or
    the temporary written, after the work and with the folders above it already made."""
    try:
        name_max = os.pathconf(folder, "PC_NAME_MAX")
        path_max = os.pathconf(folder, "PC_PATH_MAX")
    except (OSError, ValueError):  # no limit known: the write says it, if it comes to that
        return
    tmp = temporary_name(final.name, "x" * 8)  # as long as io/atomic.py's temporary
    too_long = any(len(os.fsencode(n)) > name_max for n in [*to_make, tmp])
    if too_long or len(os.fsencode(final.absolute().parent / tmp)) >= path_max:
        raise InputError(f"cannot write ({os.strerror(errno.ENAMETOOLONG)})", file=final)


def cannot_write(final: Path, exc: OSError) -> RunError:
    """A write that failed during the run (exit 1), as one line naming the file:
    ``FILE: cannot write (No space left on device)``."""
    return RunError(f"{final}: cannot write ({_reason(exc)})")


def _reason(exc: OSError) -> str:
    return exc.strerror or os.strerror(exc.errno or errno.EIO)


# -- the journal ---------------------------------------------------------------------
def needs_journal(final: Path) -> bool:
    """Files without marops metadata in their content are recorded in the journal (and
    those a writer asks for, :meth:`~marops_cli.io.atomic.OutputSet.path_for`)."""
    return final.suffix.lower() not in _WITH_METADATA


@contextmanager
def _journals_read_once() -> Iterator[None]:
    """Within: each folder's journal is read once, however many files of the folder are
    judged (a batch of outputs, which writes no journal meanwhile); an inner batch uses
    the outer one's."""
    if _JOURNALS.get() is not None:
        yield
        return
    token = _JOURNALS.set({})
    try:
        yield
    finally:
        _JOURNALS.reset(token)


def _journal_doc(folder: Path) -> dict[str, Any] | None:
    """``folder``'s journal when the file by its name is one of marops' (a regular file
    of its format), else None; read once per folder within :func:`_journals_read_once`."""
    read = _JOURNALS.get()
    if read is None:
        return _read_journal(folder)
    if folder not in read:
        read[folder] = _read_journal(folder)
    return read[folder]


def _read_journal(folder: Path) -> dict[str, Any] | None:
    journal = folder / JOURNAL
    try:
        doc = parse_json(read_small_text(journal, "file journal")) if journal.is_file() else None
    except (OSError, ValueError, InputError):
        return None
    return doc if isinstance(doc, dict) and doc.get("format") == JOURNAL_FORMAT else None


def _journal(folder: Path) -> dict[str, list[str]]:
    doc = _journal_doc(folder)
    if doc is None:
        return {}
    files = doc.get("files")
    if not isinstance(files, dict):
        return {}
    return {k: v for k, v in files.items() if isinstance(v, list)}


def journal_update(folder: Path, written: dict[str, str], tmp: Path) -> None:
    """Write into the temporary ``tmp`` ``folder``'s journal with ``written`` (name ->
    SHA-256 of the new content) added, for the caller to rename into place with the
    files. Each entry keeps the previous hash too, so the file is marops's before and
    after its rename; entries of files gone are dropped."""
    files = _journal(folder)
    for name, digest in written.items():
        files[name] = [digest, *[h for h in files.get(name, [])[:1] if h != digest]]
    files = {k: v for k, v in files.items() if k in written or (folder / k).is_file()}
    doc = {"format": JOURNAL_FORMAT, "files": dict(sorted(files.items()))}
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump(doc, fh, indent=2)
        fh.write("\n")


@contextmanager
def folder_held(folder: Path) -> Iterator[None]:
    """Two processes committing into one folder update its journal one after the other."""
    import fcntl

    fd = os.open(folder, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock
