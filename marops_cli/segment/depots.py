"""Depots, their service areas and action candidates (docs/method.md §2, paper Alg. 1)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from ..config import MAX_DEPOTS, check_range_table
from ..data.filemodel import FileModel, Whole, json_kind, validated
from ..data.frame import Frame
from ..data.jsonfile import json_number
from ..errors import InputError

MAX_DEPOT_OFFSET_M = 1_000_000.0
"""How far from its study frame's centre a depot of a depots file may lie (docs/config.md):
any real service area is far closer; a farther one is a bad file, not a depot."""


def nearest_depot(xy: np.ndarray, depots_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each point's nearest depot and the distance to it (m); ties go to the lower depot id.

    ``xy`` is ``(P, 2)``, ``depots_xy`` ``(N, 2)``. In chunks: a city's million points
    never build a points x depots matrix at once.
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    ids = np.empty(xy.shape[0], dtype=np.int64)
    dist = np.empty(xy.shape[0])
    step = max(1, 2_000_000 // max(depots_xy.shape[0], 1))
    for i in range(0, xy.shape[0], step):
        p = xy[i : i + step]
        d = np.hypot(p[:, None, 0] - depots_xy[None, :, 0], p[:, None, 1] - depots_xy[None, :, 1])
        ids[i : i + step] = np.argmin(d, axis=1)  # the first minimum: the lower id
        dist[i : i + step] = d[np.arange(p.shape[0]), ids[i : i + step]]
    return ids, dist


def nearest_candidates(xy: np.ndarray, n_actions: int) -> np.ndarray:
    """Each depot's action candidates: itself first, then its nearest other depots.

    Ties in distance go to the lower depot id, so the table is reproducible.
    Returns an ``(N, min(n_actions, N))`` int array.
    """
    n = xy.shape[0]
    k = min(n_actions, n)
    d = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1])
    np.fill_diagonal(d, -1.0)  # itself always first
    order = np.lexsort((np.broadcast_to(np.arange(n), (n, n)), d), axis=1)
    return _connected(order[:, :k].astype(np.int64), d)


def _components(cand: np.ndarray) -> np.ndarray:
    """Each depot's strongly connected component of the moves ``i -> cand[i, 1:]``,
    numbered by their lowest depot id (0 holds depot 0)."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    n = cand.shape[0]
    rows = np.repeat(np.arange(n), cand.shape[1] - 1)
    graph = csr_matrix((np.ones(rows.size), (rows, cand[:, 1:].ravel())), shape=(n, n))
    labels = connected_components(graph, directed=True, connection="strong")[1]
    first = np.unique(labels, return_index=True)[1]  # each component's lowest depot
    return np.argsort(np.argsort(first, kind="stable"), kind="stable")[labels]


def _connected(cand: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``cand`` with the moves between depots made to reach every depot from every other
    (docs/method.md §2): the nearest depots alone can leave a group of depots that no
    move enters, or one no move leaves (a village across a field, an island, the end of a
    corridor); a parcel leaves only from its own depot, so no drone from elsewhere could
    ever fly the first group's parcels, and a drone in the second could never leave.

    Where the moves already connect every depot, or each depot has one move alone (every
    depot would have to lie on one cycle), ``cand`` is returned as it is. Else,
    among the groups of mutually reachable depots, each group no move leaves gets a move
    to the nearest depot outside it, and each group no move enters a move from the
    nearest depot outside it, in place of the moving depot's farthest move that leaves
    its own group (else its farthest move); a pass that joins no groups links them all
    in a round instead (from depot 0's group to the nearest group not yet visited, and
    back). Repeated until connected (kept only where it joins groups); ties go to the lower
    depot id, so the table is reproducible."""
    n, k = cand.shape
    if n < 3 or k < 3:  # a single move per depot: every depot in one cycle or none
        return cand
    labels = _components(cand)
    before = m = int(labels.max()) + 1
    if m == 1:
        return cand
    original, cand = cand, cand.copy()
    kept = np.zeros(cand.shape, dtype=bool)  # the moves added, never replaced
    kept[:, 0] = True
    groups = n + 1
    for _ in range(2 * n):
        members = [np.flatnonzero(labels == c) for c in range(m)]
        if m < groups:
            leaves = np.zeros(m, dtype=bool)
            enters = np.zeros(m, dtype=bool)
            cross = labels[cand[:, 1:]] != labels[:, None]
            rows = np.nonzero(cross)
            leaves[labels[rows[0]]] = True
            enters[labels[cand[:, 1:][rows]]] = True
            for c in range(m):
                outside = np.flatnonzero(labels != c)
                if not leaves[c]:
                    _link(cand, kept, d, members[c], outside, labels)
                if not enters[c]:
                    _link(cand, kept, d, outside, members[c], labels)
        else:
            gap = np.full((m, m), np.inf)
            for a in range(m):
                for b in range(m):
                    if a != b:
                        gap[a, b] = d[np.ix_(members[a], members[b])].min()
            tour, left = [0], set(range(1, m))
            while left:
                nxt = min(left, key=lambda c: (gap[tour[-1], c], c))
                tour.append(nxt)
                left.remove(nxt)
            for a, b in zip(tour, tour[1:] + tour[:1], strict=True):
                _link(cand, kept, d, members[a], members[b], labels)
        groups = m
        labels = _components(cand)
        m = int(labels.max()) + 1
        if m == 1:
            return cand
    return cand if m < before else original


def _link(
    cand: np.ndarray,
    kept: np.ndarray,
    d: np.ndarray,
    source: np.ndarray,
    target: np.ndarray,
    labels: np.ndarray,
) -> None:
    """Give the depot of ``source`` nearest ``target`` a move to the depot of ``target``
    nearest it (the nearest pair whose source has a move left to give)."""
    block = d[np.ix_(source, target)]
    for flat in np.lexsort((np.arange(block.size), block.ravel())):
        i, j = int(source[flat // target.size]), int(target[flat % target.size])
        if j in cand[i]:
            kept[i, int(np.flatnonzero(cand[i] == j)[0])] = True
            return
        free = np.flatnonzero(~kept[i])
        if free.size == 0:
            continue
        leaving = free[labels[cand[i, free]] != labels[i]]
        slot = int((leaving if leaving.size else free)[-1])
        cand[i, slot], kept[i, slot] = j, True
        return


@dataclass
class Depots:
    """Depot positions in the study frame, with their action candidates.

    The service area of a depot is its Voronoi cell inside the study square: a
    point belongs to its nearest depot.
    """

    method: str
    frame: Frame
    xy: np.ndarray  # (N, 2) metres
    n_history: np.ndarray  # (N,) history requests in each area
    candidates: np.ndarray  # (N, A) depot ids, itself first
    arrivals: np.ndarray | None = None
    """(N, W) requests becoming visible in each area and window on a typical history
    day (docs/method.md §6, anticipation features); None when unknown."""

    def __len__(self) -> int:
        return int(self.xy.shape[0])

    @property
    def n_actions(self) -> int:
        return int(self.candidates.shape[1])

    def lnglat(self) -> tuple[np.ndarray, np.ndarray]:
        return self.frame.to_lnglat(self.xy[:, 0], self.xy[:, 1])

    def assign(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Service area (depot id) of each point: its nearest depot, ties to the lower id
        (:func:`nearest_depot`)."""
        x = np.asarray(x, dtype=np.float64).reshape(-1)
        y = np.asarray(y, dtype=np.float64).reshape(-1)
        return nearest_depot(np.column_stack([x, y]), self.xy)[0]

    def with_actions(self, n_actions: int) -> Depots:
        """The same depots with a different number of action candidates."""
        return Depots(
            self.method,
            self.frame,
            self.xy,
            self.n_history,
            nearest_candidates(self.xy, n_actions),
            self.arrivals,
        )

    def to_dict(self, meta: dict[str, Any]) -> dict[str, Any]:
        """The ``depots.json`` document of docs/outputs.md."""
        lng, lat = self.lnglat()
        return {
            "meta": meta,
            "method": self.method,
            "frame": self.frame.to_dict(),
            "depots": [
                {
                    "id": i,
                    "x_m": round(float(self.xy[i, 0]), 3),
                    "y_m": round(float(self.xy[i, 1]), 3),
                    "lng": round(float(lng[i]), 7),
                    "lat": round(float(lat[i]), 7),
                    "n_history": int(self.n_history[i]),
                }
                for i in range(len(self))
            ],
            "candidates": {str(i): [int(c) for c in self.candidates[i]] for i in range(len(self))},
        }

    @classmethod
    def from_dict(cls, doc: dict[str, Any], source: str = "depots.json") -> Depots:
        listed = doc.get("depots") if isinstance(doc, dict) else None
        if isinstance(listed, list) and len(listed) > MAX_DEPOTS:  # before any depot's work
            raise InputError(
                f"lists {len(listed):,} depots, more than the {MAX_DEPOTS} one study area "
                "has (segment.n_depots, docs/config.md)",
                file=source,
                column="depots",
            )
        file = validated(DepotsFile, doc, source)
        if not file.depots:
            raise InputError("the depots file lists no depots", file=source)
        ids = [d.id for d in file.depots]
        if sorted(ids) != list(range(len(ids))):
            raise InputError(
                f"expected the depot ids 0..{len(ids) - 1} (whole numbers), each once: "
                + _id_fault(ids),
                file=source,
                column="depots[].id",
            )
        order = sorted(range(len(ids)), key=lambda i: ids[i])
        rows = [file.depots[i] for i in order]
        xy = np.array([[d.x_m, d.y_m] for d in rows], dtype=np.float64)
        n_hist = np.array([d.n_history for d in rows], dtype=np.int64)
        f = file.frame
        frame = Frame(f.center_lng, f.center_lat, f.size_km)
        cand = _candidates(file.candidates, len(rows), source)
        _same_places(rows, order, frame, xy, source)
        return cls(file.method, frame, xy, n_hist, cand)

    @classmethod
    def load(cls, path: str | Path, n_actions: int | None = None) -> Depots:
        """The depots of a depots file of at most :data:`MAX_DEPOTS_FILE` bytes;
        ``n_actions``: the action candidates the run gives each depot, refused (naming
        the file) when the flight-range table of these depots would be too large."""
        from ..data.jsonfile import read_json

        depots = cls.from_dict(
            read_json(path, "depots file", limit=MAX_DEPOTS_FILE), source=str(path)
        )
        depots.check_actions(n_actions, path)
        return depots

    def check_actions(self, n_actions: int | None, file: str | Path) -> None:
        """Refuse ``n_actions`` action candidates (None: none asked) whose flight-range
        table over these depots would be too large, naming ``file``."""
        if n_actions is None:
            return
        try:
            check_range_table(len(self), n_actions, ("", "segment.n_actions"))
        except ValueError as exc:
            raise InputError(f"{exc}", file=file, column="depots") from None


MAX_DEPOTS_FILE = 16 << 20
"""Bytes a depots file may have (docs/config.md): one of :data:`MAX_DEPOTS` depots as
marops writes it takes under 2 MiB; a larger file is refused before it is parsed."""


MAX_HISTORY = 2**53
"""The largest count of history requests a depots file's ``n_history`` may give."""
_NOT_DEPOTS = "not a marops depots file: "
_OFFSET = (
    f"metres from the study frame's centre, within {MAX_DEPOT_OFFSET_M / 1000:,.0f} km "
    "(docs/config.md)"
)


_CANDIDATES_SHAPE = '{"0": [0, 4, 1], "1": [1, 0, 2], …}, each depot\'s id to its candidates'
"""What ``candidates`` holds, as its errors say it (:meth:`Depots.to_dict` writes it)."""


class _Frame(FileModel):
    """The study frame of a depots file (:meth:`Frame.to_dict`)."""

    noun: ClassVar[str] = "the frame"
    prefix: ClassVar[str] = _NOT_DEPOTS
    center_lng: float = Field(ge=-180, le=180)
    center_lat: float = Field(ge=-90, le=90)
    size_km: float = Field(gt=0, le=200)


class _Depot(FileModel):
    """One depot of a depots file: where it is (``x_m``, ``y_m`` place it; ``lng`` and
    ``lat``, when given, must agree) and its history requests."""

    noun: ClassVar[str] = "depot"
    id: Whole
    x_m: float = Field(ge=-MAX_DEPOT_OFFSET_M, le=MAX_DEPOT_OFFSET_M, description=_OFFSET)
    y_m: float = Field(ge=-MAX_DEPOT_OFFSET_M, le=MAX_DEPOT_OFFSET_M, description=_OFFSET)
    lng: float | None = None
    lat: float | None = None
    n_history: Whole = Field(0, ge=0, le=MAX_HISTORY, description="a count from 0 to 2^53")


class DepotsFile(FileModel):
    """A depots file (docs/outputs.md, :meth:`Depots.to_dict`): its parts' own shapes;
    :meth:`Depots.from_dict` checks what they say of each other."""

    noun: ClassVar[str] = "depots file"
    shape: ClassVar[str] = "an object with frame, depots and candidates"
    prefix: ClassVar[str] = _NOT_DEPOTS
    meta: dict[str, Any] = Field(default_factory=dict, description="the provenance object")
    method: Literal["kmeans", "squares"] = Field(
        "kmeans", description="the segmentation method's name, kmeans or squares"
    )
    frame: _Frame = Field(description="the frame {center_lng, center_lat, size_km}")
    depots: list[_Depot] = Field(description="a list of depots")
    candidates: dict[str, Any] = Field(
        description=f"{_CANDIDATES_SHAPE}, itself first, all lists as long"
    )


def _candidates(value: dict[str, Any], n: int, source: str) -> np.ndarray:
    """The ``candidates`` of a depots file of ``n`` depots as an (n, A) array of depot
    ids: each depot lists itself first, every list as long. A value of another shape is
    refused naming its key and the expected shape."""
    shape = f"expected {_CANDIDATES_SHAPE}, itself first, all lists as long"
    extra = sorted(set(value) - {str(i) for i in range(n)})
    if extra:
        raise InputError(
            f"no depot has the id {extra[0]!r} (ids 0..{n - 1}); {shape}",
            file=source,
            column=f"candidates.{extra[0]}",
        )
    rows: list[list[int]] = []
    for i in range(n):
        key = f"candidates.{i}"
        listed = value.get(str(i))
        if not isinstance(listed, list) or not listed:
            got = "nothing" if str(i) not in value else json_kind(listed)
            raise InputError(f"{shape}; got {got} for depot {i}", file=source, column=key)
        if rows and len(listed) != len(rows[0]):
            raise InputError(
                f"{shape}; got {len(listed)} candidates for depot {i}, {len(rows[0])} for depot 0",
                file=source,
                column=key,
            )
        # Ids as written: 3.9, "3" or true are no depot id (int() would make them one).
        ids = [json_number(c, source, key, whole=True) for c in listed]
        if not all(0 <= c < n for c in ids):
            raise InputError(
                f"candidates refer to unknown depots (ids 0..{n - 1})", file=source, column=key
            )
        if ids[0] != i:
            raise InputError(
                f"each depot must list itself first; depot {i} lists {int(ids[0])}",
                file=source,
                column=key,
            )
        rows.append([int(c) for c in ids])
    return np.array(rows, dtype=np.int64)


_PLACE_TOLERANCE_M = 1.0
"""How far a depot's lng/lat may lie from its x_m/y_m (both are rounded when written)."""


def _same_places(
    rows: list[_Depot], order: list[int], frame: Frame, xy: np.ndarray, source: str
) -> None:
    """Refuse a depot whose ``lng``/``lat`` disagree with its ``x_m``/``y_m``: marops
    places depots by ``x_m``/``y_m``, so a position edited in degrees alone would be
    silently ignored."""
    for k, (i, d) in enumerate(zip(order, rows, strict=True)):
        if d.lng is None and d.lat is None:
            continue
        if d.lng is None or d.lat is None:
            half = "lng" if d.lng is None else "lat"
            raise InputError(
                "a depot gives both lng and lat, or neither",
                file=source,
                column=f"depots[{i}].{half}",
            )
        x, y = frame.to_xy(np.array([d.lng]), np.array([d.lat]))
        off = float(np.hypot(x[0] - xy[k, 0], y[0] - xy[k, 1]))
        if off > _PLACE_TOLERANCE_M:
            raise InputError(
                f"depot {d.id}'s lng/lat lie {off:,.0f} m from its x_m/y_m, which place it: "
                "edit both (or leave lng and lat out)",
                file=source,
                column=f"depots[{i}].lng",
            )


def _id_fault(ids: list[int]) -> str:
    """What is wrong with a depots file's ids (whole numbers), at the first depot at fault."""
    seen: set[int] = set()
    for k, v in enumerate(ids):
        if not 0 <= v < len(ids):
            return f"depots[{k}] has id {v}, outside 0..{len(ids) - 1}"
        if v in seen:
            return f"depots[{k}] has id {v}, as an earlier depot does"
        seen.add(v)
    return "an id is missing"
