"""Depots cached by what they are made from (docs/outputs.md, "Depots cache").

Segmenting the history days (k-means) is the slowest part of a run that is not given
``--depots``; its result depends only on the input file's bytes, the history days,
the study frame and the ``[data]`` and ``[segment]`` settings. The depots are kept
under the hash of those, exactly (``.npz``: positions to the last bit, so a run from
the cache plans the same bytes as the run that filled it), in ``$MAROPS_CACHE_DIR``
(default ``$XDG_CACHE_HOME/marops`` or ``~/.cache/marops``); ``MAROPS_CACHE_DIR=off``
turns the cache off. A cache that cannot be written is skipped silently: it only
ever saves time.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import hashlib
import json
import os
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from .. import __version__
from ..config import DataConfig, SegmentConfig
from ..data.frame import Frame
from ..data.table import LadeTable
from .depots import Depots

__all__ = ["cache_dir", "cached_depots", "depots_key"]

_FORMAT = 1  # bump when the stored arrays change meaning


def cache_dir() -> Path | None:
    """Where depots are cached; None when ``MAROPS_CACHE_DIR=off`` or when it names a
    home that cannot be found."""
    env = os.environ.get("MAROPS_CACHE_DIR", "").strip()
    if env.lower() in ("off", "0", "none", "false"):
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


def _load(path: Path, key: str, frame: Frame, segment: SegmentConfig) -> Depots | None:
    """The cached depots, or None (segment again, and cache anew) when the file is
    unreadable, from another format, made for another key (a file copied or renamed
    into the cache), or holds what no segmentation makes: a damaged or edited cache
    must not stop a run, nor move its depots."""
    try:
        with np.load(path, allow_pickle=False) as z:
            stored = str(z["key"])
            method = str(z["method"])
            xy, n_hist, cand = z["xy"], z["n_history"], z["candidates"]
    except Exception:  # noqa: BLE001 - zip, format and dtype errors alike mean a miss
        return None
    if stored != key or method != segment.method:
        return None
    if not _plausible(xy, n_hist, cand, frame):
        return None
    return Depots(
        method, frame, xy.astype(np.float64), n_hist.astype(np.int64), cand.astype(np.int64)
    )


def _plausible(xy: np.ndarray, n_hist: np.ndarray, cand: np.ndarray, frame: Frame) -> bool:
    """Depots inside the study square, a history count each, and action candidates that
    are depot ids with each depot its own first."""
    n = xy.shape[0] if xy.ndim == 2 else 0
    if n == 0 or xy.shape != (n, 2) or n_hist.shape != (n,) or cand.ndim != 2:
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


def _store(path: Path, key: str, depots: Depots) -> None:
    """Cache ``depots`` at ``path`` under a temporary name then renamed; where that
    fails (a full disk, a folder in the way) nothing is left behind. The temporary is
    made new (``O_EXCL``): a link planted under a name it could take is never written
    through."""
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
            )
        os.replace(tmp, path)
    except OSError:
        if tmp is not None:
            with contextlib.suppress(OSError):
                tmp.unlink(missing_ok=True)


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
    if path.is_file():
        hit = _load(path, key, frame, segment)
        if hit is not None:
            return hit
    depots = make()
    _store(path, key, depots)
    return depots
