"""Depots cached by what they are made from (docs/outputs.md, "Depots cache").

Segmenting the history days (k-means) is the slowest part of a run that is not given
``--depots``; its result depends only on the input file's bytes, the history days,
the study frame and the ``[data]`` and ``[segment]`` settings. The depots are kept
under the hash of those, exactly (``.npz``: positions to the last bit, so a run from
the cache plans the same bytes as the run that filled it), in ``$MAROPS_CACHE_DIR``
(default ``$XDG_CACHE_HOME/marops`` or ``~/.cache/marops``); ``MAROPS_CACHE_DIR=off``
turns the cache off. A cache that cannot be written is skipped silently: it only
ever saves time.

An entry is used only when it is one this user's runs could have written and no one
else could have changed: a regular file (no link) owned by this user that others may
not write, checked on the very file read (as the installation's record of trained
actors is, docs/method.md §6). Any other entry under a key's name (another user's, one
others may write, in a cache folder shared with them) is not used, nor replaced: the
run segments again and says so in a warning.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import errno
import hashlib
import json
import os
import stat
import tempfile
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextvars import ContextVar
from pathlib import Path

import numpy as np

from .. import __version__
from ..config import MAX_DEPOTS, DataConfig, SegmentConfig
from ..data.frame import Frame
from ..data.table import LadeTable
from .depots import Depots

__all__ = ["cache_dir", "cache_named_only", "cached_depots", "depots_key"]

_FORMAT = 3  # bump when the stored arrays change meaning (2: moves reach every depot;
# 3: k-means of the points in a canonical order)
MAX_ENTRY = 16 << 20
"""Bytes of a cache entry read at most, as stored and as its arrays unpack:
:data:`MAX_DEPOTS` depots with the action candidates a run may have (docs/config.md) take
under 4 MiB; a larger entry is a miss."""


_NAMED_ONLY: ContextVar[bool] = ContextVar("depots_cache_named_only", default=False)


@contextlib.contextmanager
def cache_named_only(only: bool = True) -> Iterator[None]:
    """Within, with ``only``: depots are cached only when ``MAROPS_CACHE_DIR`` names the
    cache's folder, never in the default one (the Python API called without ``out``,
    which writes nothing it was not asked to)."""
    token = _NAMED_ONLY.set(only)
    try:
        yield
    finally:
        _NAMED_ONLY.reset(token)


def cache_dir() -> Path | None:
    """Where depots are cached; None when ``MAROPS_CACHE_DIR=off``, when it names a
    home that cannot be found, or when it is not set within :func:`cache_named_only`."""
    env = os.environ.get("MAROPS_CACHE_DIR", "").strip()
    if env.lower() in ("off", "0", "none", "false") or (not env and _NAMED_ONLY.get()):
        return None
    base = os.environ.get("XDG_CACHE_HOME", "").strip()
    try:  # a home that cannot be found (~user of no user, no HOME): no cache, no error
        if env:
            return Path(env).expanduser()
        # A relative XDG_CACHE_HOME is invalid (XDG Base Directory): not a folder in
        # whatever directory the run started from.
        xdg = Path(base) if base and Path(base).is_absolute() else Path.home() / ".cache"
        return xdg / "marops"
    except (RuntimeError, KeyError):
        return None


def depots_key(
    source_sha256: str,
    days: Sequence[dt.date],
    frame: Frame,
    data: DataConfig,
    segment: SegmentConfig,
) -> str:
    """The hash of everything the depots are made from."""
    doc = {
        "format": _FORMAT,
        "version": __version__,
        "source": source_sha256,
        "days": [d.isoformat() for d in days],
        "frame": frame.to_dict(),
        "data": data.model_dump(mode="json"),
        "segment": segment.model_dump(mode="json"),
    }
    return hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()


def _open_own(path: Path) -> tuple[int | None, str | None]:
    """A descriptor of the cache entry ``path`` when it is this user's alone, else why it
    is not trusted (None: there is none, or none that can be opened: a miss). Checked on
    the open descriptor, so the file read is the file checked; a link is never
    followed."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except OSError as exc:  # none, or a cache folder that cannot be read: a miss
        return None, "is a symbolic link" if exc.errno == errno.ELOOP else None
    try:
        info = os.fstat(fd)
    except OSError:
        info = None
    reason = None
    if info is None:
        reason = ""  # a miss, said by no warning
    elif not stat.S_ISREG(info.st_mode):
        reason = "is not a regular file"
    elif info.st_uid != os.getuid():
        reason = f"belongs to another user (uid {info.st_uid})"
    elif info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        reason = "may be written by other users"
    elif info.st_size > MAX_ENTRY:
        reason = ""  # larger than any: damaged, a miss
    if reason is not None:
        os.close(fd)
        return None, reason or None
    return fd, None


def _load(
    path: Path, key: str, frame: Frame, segment: SegmentConfig
) -> tuple[Depots | None, str | None]:
    """The cached depots, or None (segment again) when there is no entry, or it is not
    this user's alone (then why: :func:`_open_own`), unreadable, from another format,
    made for another key (a file copied or renamed into the cache), or holds what no
    segmentation makes: a damaged or edited cache must not stop a run, nor move its
    depots."""
    fd, distrust = _open_own(path)
    if fd is None:
        return None, distrust
    try:
        with os.fdopen(fd, "rb") as fh, np.load(fh, allow_pickle=False) as z:
            # Compressed members (np.savez_compressed) are read whole into memory: what
            # they unpack to is bounded as the file is (2 MiB of zeros unpack to 2 GiB).
            if sum(info.file_size for info in z.zip.infolist()) > MAX_ENTRY:
                return None, None
            stored = str(z["key"])
            method = str(z["method"])
            xy, n_hist, cand = z["xy"], z["n_history"], z["candidates"]
            digest = str(z["digest"])
    except Exception:  # noqa: BLE001 - zip, format and dtype errors alike mean a miss
        return None, None
    if stored != key or method != segment.method:
        return None, None
    if not _plausible(xy, n_hist, cand, frame) or digest != _digest(key, method, xy, n_hist, cand):
        return None, None  # damaged or edited since it was stored
    depots = Depots(
        method, frame, xy.astype(np.float64), n_hist.astype(np.int64), cand.astype(np.int64)
    )
    return depots, None


def _plausible(xy: np.ndarray, n_hist: np.ndarray, cand: np.ndarray, frame: Frame) -> bool:
    """Depots inside the study square, a history count each, and action candidates that
    are depot ids with each depot its own first."""
    n = xy.shape[0] if xy.ndim == 2 else 0
    if not 0 < n <= MAX_DEPOTS or xy.shape != (n, 2) or n_hist.shape != (n,) or cand.ndim != 2:
        return False
    if cand.shape[0] != n or cand.shape[1] < 1:
        return False
    if not all(np.issubdtype(a.dtype, np.number) for a in (xy, n_hist, cand)):
        return False
    if not (np.all(np.isfinite(xy)) and np.abs(xy).max() <= frame.half_m * (1 + 1e-9)):
        return False
    if not (np.issubdtype(cand.dtype, np.integer) and np.issubdtype(n_hist.dtype, np.integer)):
        return False
    return bool(
        n_hist.min() >= 0
        and cand.min() >= 0
        and cand.max() < n
        and np.array_equal(cand[:, 0], np.arange(n))
    )


def _digest(key: str, method: str, xy: np.ndarray, n_hist: np.ndarray, cand: np.ndarray) -> str:
    """The SHA-256 of an entry's key and arrays, stored with them: an entry whose
    numbers were edited or damaged since (a depot moved 500 m still looks plausible)
    no longer matches it, and is segmented again."""
    h = hashlib.sha256(f"{key}\0{method}\0".encode())
    for a, dtype in ((xy, "<f8"), (n_hist, "<i8"), (cand, "<i8")):
        h.update(repr(a.shape).encode())
        h.update(np.ascontiguousarray(a, dtype=dtype).tobytes())
    return h.hexdigest()


def _store(path: Path, key: str, depots: Depots) -> None:
    """Cache ``depots`` at ``path`` under a temporary name then renamed; where that
    fails (a full disk, a folder in the way) nothing is left behind. The temporary is
    made new (``O_EXCL``): a link planted under a name it could take is never written
    through. What lies at ``path`` by then is replaced only when it is a file of this
    user's: another user's entry, a link or a folder stays as it is."""
    tmp: Path | None = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        tmp = Path(name)
        os.fchmod(fd, 0o644)  # readable by the others sharing the cache, as before (0600)
        with os.fdopen(fd, "wb") as fh:
            np.savez(
                fh,
                key=np.array(key),
                method=np.array(depots.method),
                xy=depots.xy,
                n_history=depots.n_history,
                candidates=depots.candidates,
                digest=np.array(
                    _digest(key, depots.method, depots.xy, depots.n_history, depots.candidates)
                ),
            )
        with contextlib.suppress(FileNotFoundError):
            there = os.lstat(path)
            if not stat.S_ISREG(there.st_mode) or there.st_uid != os.getuid():
                raise OSError(errno.EEXIST, "another user's entry")  # left as it is
        os.replace(tmp, path)
    except BaseException as exc:  # Ctrl-C or SIGTERM as it is written too: never left
        if tmp is not None:
            with contextlib.suppress(OSError):
                tmp.unlink(missing_ok=True)
        if not isinstance(exc, OSError):
            raise


def cached_depots(
    table: LadeTable,
    days: Sequence[dt.date],
    frame: Frame,
    data: DataConfig,
    segment: SegmentConfig,
    make: Callable[[], Depots],
) -> Depots:
    """The cached depots made from ``table``'s rows of ``days`` in ``frame`` with these
    settings, else ``make()``'s (then cached). The key is only computed when the cache is
    on: hashing a city's rows is not free."""
    root = cache_dir()
    if root is None:
        return make()
    rows = hashlib.sha256(np.ascontiguousarray(table.row).tobytes()).hexdigest()
    key = depots_key(f"{table.source.sha256}:{rows}", days, frame, data, segment)
    path = root / "depots" / f"{key}.npz"
    hit, distrust = _load(path, key, frame, segment)
    if hit is not None:
        return hit
    if distrust is not None:
        warnings.warn(
            f"depots cache entry {path} {distrust}: not used, the depots are segmented "
            'again (docs/outputs.md, "Depots cache")',
            stacklevel=2,
        )
    depots = make()
    _store(path, key, depots)  # never over another user's entry, a link or a folder
    return depots
