"""Hubs: a city tiled into study areas, each with its own depots and fleet
(docs/method.md §1.1, docs/outputs.md "Hubs file").

A hub is a study square. :func:`find_hubs` places disjoint squares densest first
(:func:`~marops_cli.data.frame.hub_squares`); a hubs file can also be written by hand
(centres, optionally sizes and fleet sizes). Every order belongs to at most one hub:
the first, in hub order, whose square holds it (:func:`hub_owner`), so no order is
planned twice where two squares touch.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from pydantic import Field

from ..config import MAX_DRONES, DataConfig, PlannerConfig, override
from ..data.dates import format_days
from ..data.filemodel import FileModel, Whole, validated
from ..data.frame import REACH_M, Frame, hub_squares, within_reach
from ..data.jsonfile import read_json
from ..data.prepare import check_days_in_file, due_on, prepare_day
from ..data.table import LadeTable
from ..errors import InputError, naming, option

__all__ = [
    "MAX_HUBS",
    "Hub",
    "HubArea",
    "find_hubs",
    "hub_areas",
    "hub_demand",
    "hub_locations",
    "hub_owner",
    "hubs_history",
    "hubs_doc",
    "load_hubs",
    "place_hubs",
    "share_fleet",
    "with_fleets",
]

MAX_HUBS = 256
"""The most hubs a city is tiled into (a hubs file, ``--hubs N``; docs/config.md). 256
squares of the default 10 km cover 25,600 km², more than any city (Beijing's whole
municipality is 16,410 km²; ``--hubs auto`` places at most 100, each holding 1 % of the
orders), while every hub is a study area of its own, holding its own copy of the file's
rows it may plan: memory grows with hubs × rows (about 60 bytes a row each)."""
MAX_HUBS_FILE = 1 << 20
"""Bytes a hubs file may have: :data:`MAX_HUBS` hubs as marops writes them take under
100 KiB; a larger file is refused before it is parsed."""


@dataclass(frozen=True)
class Hub:
    """One study area of a city."""

    id: int
    frame: Frame
    orders: int = 0
    """Orders its square held on the days it was placed from (0: unknown)."""
    drones: int | None = None
    """Its fleet size; None: the run's ``--drones``."""


def find_hubs(
    table: LadeTable,
    cfg: DataConfig,
    days: Sequence[dt.date] | None,
    n_hubs: int | None,
    min_share: float = 0.01,
    cover: bool = False,
) -> tuple[list[Hub], int]:
    """Hubs over the orders due on ``days`` (all when None), densest first: ``n_hubs``
    of them, or (None) while the next holds at least ``min_share`` of the orders; with
    ``cover`` each next hub is the square adding the most orders no hub before holds
    (:func:`~marops_cli.data.frame.hub_squares`). Returns the hubs and the number of
    orders they were placed from."""
    check_days_in_file(table, list(days or ()))  # every row dropped: says why
    mask = due_on(table, days) if days else np.ones(len(table), dtype=bool)
    if not mask.any():
        raise InputError("no requests to place hubs on", file=table.source.path)
    try:
        squares = hub_squares(
            table.lng[mask], table.lat[mask], cfg.size_km, cfg.grid_m, n_hubs, min_share, cover
        )
    except InputError as exc:
        raise naming(exc, table.source.path) from None
    # Each hub's count is the orders it owns (:func:`hub_owner`), those it plans: the
    # grid's count of its cells misses by a cell's edge where the square's side is no
    # whole number of grid steps, or where the grid's plane and the square's part.
    frames = [f for f, _ in squares]
    owner = _owner(table.lng[mask], table.lat[mask], frames)
    held = np.bincount(owner[owner >= 0], minlength=len(frames))
    hubs = [Hub(i, f, int(held[i])) for i, f in enumerate(frames)]
    return hubs, int(mask.sum())


def hubs_doc(hubs: Sequence[Hub], total: int, meta: dict[str, Any]) -> dict[str, Any]:
    """The hubs file (docs/outputs.md, "Hubs file")."""
    return {
        "meta": meta,
        "orders": total,
        "hubs": [
            {
                "id": h.id,
                "center_lng": h.frame.center_lng,
                "center_lat": h.frame.center_lat,
                "size_km": h.frame.size_km,
                "orders": h.orders,
                "share": h.orders / total if total else 0.0,
                **({"drones": h.drones} if h.drones is not None else {}),
            }
            for h in hubs
        ],
    }


class _Hub(FileModel):
    """A hub of a hubs file (what ``marops segment --hubs`` writes, docs/outputs.md): its
    centre, optionally its size and fleet; ``id``, ``orders`` and ``share`` as written."""

    noun: ClassVar[str] = "hub"
    id: Whole | None = None
    center_lng: float = Field(ge=-180, le=180, description="a longitude, a number from -180 to 180")
    center_lat: float = Field(ge=-90, le=90, description="a latitude, a number from -90 to 90")
    size_km: float | None = Field(None, gt=0, le=200, description="a size in km in (0, 200]")
    orders: Whole = Field(0, ge=0, description="a count of orders, a whole number from 0")
    share: float | None = None
    drones: Whole | None = Field(
        None,
        ge=1,
        le=MAX_DRONES,
        description=f"a hub's fleet, a whole number of 1..{MAX_DRONES} drones (docs/config.md)",
    )


class _HubsFile(FileModel):
    """A hubs file: ``{"hubs": [...]}`` (or the list itself, read as this)."""

    noun: ClassVar[str] = "hubs file"
    meta: dict[str, Any] = Field(default_factory=dict, description="the provenance object")
    orders: Whole | None = Field(None, ge=0, description="a count of orders, a whole number from 0")
    hubs: list[_Hub] = Field(min_length=1, description="a list of hubs under 'hubs'")


def load_hubs(path: str | Path, cfg: DataConfig) -> list[Hub]:
    """The hubs of a hubs file: ``{"hubs": [{center_lng, center_lat, size_km?, drones?}]}``
    (or the list itself); ``size_km`` defaults to ``cfg.size_km``; ids are list order."""
    p = Path(path)
    doc = read_json(p, "hubs file", limit=MAX_HUBS_FILE)
    if isinstance(doc, list):
        doc = {"hubs": doc}
    items = doc.get("hubs") if isinstance(doc, dict) else None
    if isinstance(items, list) and len(items) > MAX_HUBS:  # before any hub's work
        raise InputError(
            f"lists {len(items):,} hubs, more than the {MAX_HUBS} a city is tiled into "
            "(docs/config.md)",
            file=p,
            column="hubs",
        )
    hubs = []
    for i, h in enumerate(validated(_HubsFile, doc, p).hubs):
        # Ids are list order: an id written by hand that says otherwise would be ignored.
        if h.id is not None and h.id != i:
            raise InputError(
                f"expected {i}, the hub's place in the list (ids are list order), got {h.id!r}",
                file=p,
                column=f"hubs[{i}].id",
            )
        size = cfg.size_km if h.size_km is None else h.size_km
        hubs.append(Hub(i, Frame(h.center_lng, h.center_lat, size), h.orders, h.drones))
    return hubs


def hub_owner(table: LadeTable, hubs: Sequence[Hub]) -> np.ndarray:
    """Each row's hub: the id of the first (in hub order) whose square holds it, or -1."""
    first = _owner(table.lng, table.lat, [h.frame for h in hubs])
    ids = np.array([h.id for h in hubs] + [-1], dtype=np.int64)
    return ids[first]  # -1 picks the last entry, no hub


def _owner(lng: np.ndarray, lat: np.ndarray, frames: Sequence[Frame]) -> np.ndarray:
    """Each point's square: the index of the first of ``frames`` that holds it, or -1."""
    owner = np.full(len(lng), -1, dtype=np.int64)
    for i, frame in enumerate(frames):
        x, y = frame.to_xy(lng, lat)
        owner[(owner < 0) & frame.contains(x, y)] = i
    return owner


@dataclass(frozen=True)
class HubArea:
    """A hub as a study area: its config (its square; its fleet size when it has one),
    the file's rows it may plan, and the days it has requests on."""

    hub: Hub
    cfg: PlannerConfig
    table: LadeTable
    days: list[dt.date]
    skipped: list[dt.date]
    """Days its square has no request on (not replayed)."""

    def replayable(self, days: Sequence[dt.date]) -> list[dt.date]:
        """Those of ``days`` its rows hold (a hub holds its own orders alone: another
        hub's, or those outside every hub, may be all a day has)."""
        held = set(self.table.days())
        return [d for d in days if d in held]


def hub_areas(
    table: LadeTable,
    cfg: PlannerConfig,
    hubs: Sequence[Hub],
    days: Sequence[dt.date],
    owner: np.ndarray | None = None,
) -> list[HubArea]:
    """Every hub as a study area over ``days``. An order belongs to the first hub whose
    square holds it (:func:`hub_owner`; ``owner``, when the caller has it): a hub's rows
    are those it owns, so no order is planned twice, and no hub counts another's orders,
    or those outside every hub, among its own left out."""
    owner = hub_owner(table, hubs) if owner is None else owner
    areas = []
    for h in hubs:
        f = h.frame
        cfg_h = override(
            cfg,
            data__center=(f.center_lng, f.center_lat),
            data__size_km=f.size_km,
            sim__drones=h.drones,
        )
        # Its own orders only: those of earlier hubs, and those outside every hub, are
        # the city's to count (app/replay_hubs.py), not left out by every hub again.
        rows = table.subset(owner == h.id)
        kept, skipped = [], []
        for day in days:
            try:
                prepare_day(rows, f, day, cfg_h.data)
                kept.append(day)
            except InputError:
                skipped.append(day)
        areas.append(HubArea(h, cfg_h, rows, kept, skipped))
    return areas


def hubs_history(table: LadeTable, days: Sequence[dt.date]) -> list[dt.date]:
    """The days hubs are placed and fleets shared out from: the file's days other than
    ``days`` (those replayed or evaluated, as depots are segmented), or ``days`` for a
    file that has no other."""
    other = [d for d in table.days() if d not in set(days)]
    return other or list(days)


def hub_demand(
    table: LadeTable,
    hubs: Sequence[Hub],
    days: Sequence[dt.date],
    owner: np.ndarray | None = None,
) -> list[int]:
    """Each hub's demand: the orders it owns (:func:`hub_owner`; ``owner``, when the
    caller has it) due on ``days``."""
    owner = hub_owner(table, hubs) if owner is None else owner
    on = due_on(table, days)
    counts = np.bincount(owner[on & (owner >= 0)], minlength=len(hubs))
    return [int(c) for c in counts]


MIN_HUB_SHARE = 0.004
"""The least ``[data] hub_min_share`` (config.py): at most 250 hubs."""

OUTSIDE_WARNING = 0.05
"""The share of the orders due that, outside every hub the run placed, it warns of."""


def outside_warning(
    table: LadeTable,
    hubs: Sequence[Hub],
    days: Sequence[dt.date],
    min_share: float,
    owner: np.ndarray | None = None,
    *,
    history: Sequence[dt.date] | None = None,
    unplaced: int = 0,
    n_depots: int = 0,
) -> str | None:
    """A warning when at least :data:`OUTSIDE_WARNING` of the orders due on ``days`` lie
    outside every hub placed (``[data] hub_min_share`` ``min_share``; another city in the
    export, scattered points): the run leaves them out, and its figures per hub would not
    show it. ``owner``: each row's hub (:func:`hub_owner`), when the caller has it. The
    warning says why where it can: the ``history`` days the hubs were placed over hold
    their orders inside them (these days' orders lie elsewhere), or ``unplaced`` squares
    were left out, too few distinct locations for their ``n_depots`` depots
    (:func:`place_hubs`)."""
    total = int(due_on(table, days).sum())
    outside = total - sum(hub_demand(table, hubs, days, owner))
    if not total or outside < OUTSIDE_WARNING * total:
        return None
    head = (
        f"{outside:,} of the {total:,} orders due ({outside / total:.0%}) lie outside every "
        "hub, and are left out: "
    )
    if history is not None and set(history) != set(days):
        placed_on = int(due_on(table, history).sum())
        held = sum(hub_demand(table, hubs, history, owner))
        if placed_on and placed_on - held < OUTSIDE_WARNING * placed_on:
            return head + (
                f"the hubs are placed over the history days ({format_days(history)}), whose "
                f"orders they hold ({held / placed_on:.0%}), and these days' orders lie "
                f"elsewhere; name their squares in a hubs file ({option('hubs')}; marops "
                "segment --hubs auto --dates DAYS writes one)"
            )
    why = ""
    if unplaced:
        why = (
            f"{unplaced:,} {'hub was' if unplaced == 1 else 'hubs were'} not placed, each "
            "holding fewer distinct customer locations on the history days than the "
            f"{n_depots} a hub's depots need (lower {option('n_depots')}); "
        )
    reach = (
        f"hubs are placed within {REACH_M / 1000:g} km of the export's median point, where "
        f"at least {min_share * 100:g}% of its orders are ([data] hub_min_share); "
    )
    if owner is None:
        owner = hub_owner(table, hubs)
    out = due_on(table, days) & (owner < 0)
    placed = due_on(table, history if history is not None else days)
    if (
        placed.any()
        and 2
        * within_reach(table.lng[out], table.lat[out], table.lng[placed], table.lat[placed]).sum()
        >= out.sum()
    ):  # most lie within reach: the city's own sparse squares
        lower = (
            "lower it (to 0.004 at the least) to place hubs there, or "
            if min_share > MIN_HUB_SHARE
            else ""
        )
        return (
            head
            + why
            + reach
            + (
                f"most of these lie within it, in squares that each add less: {lower}name their "
                f"squares in a hubs file ({option('hubs')})"
            )
        )
    return (
        head
        + why
        + reach
        + (
            f"give another city a file of its own, or name its squares in a hubs file "
            f"({option('hubs')})"
        )
    )


def hub_locations(table: LadeTable, hubs: Sequence[Hub], days: Sequence[dt.date]) -> list[int]:
    """Each hub's distinct customer locations (``lng, lat``) among the orders it owns
    (:func:`hub_owner`) due on ``days``: k-means places one depot on each at most."""
    owner = hub_owner(table, hubs)
    on = due_on(table, days)
    mine = on & (owner >= 0)
    points = np.column_stack([owner[mine].astype(np.float64), table.lng[mine], table.lat[mine]])
    held = np.unique(points, axis=0)[:, 0].astype(np.int64)
    return [int(c) for c in np.bincount(held, minlength=len(hubs))]


def place_hubs(
    table: LadeTable, cfg: PlannerConfig, history: Sequence[dt.date], n_depots: int
) -> tuple[list[Hub], int]:
    """The hubs the whole-export run places (docs/method.md §1.1): covering squares over
    the ``history`` days (:func:`find_hubs`), less any that would own fewer distinct
    history locations (:func:`hub_locations`) than its ``n_depots`` depots need (rounded
    coordinates put many orders on one point); those orders fall to the hubs left, or
    outside every hub. Returns the hubs and the number of squares left out (the run's
    warning of orders outside every hub names them). Refused when no hub is left."""
    import dataclasses

    hubs, _ = find_hubs(table, cfg.data, history, None, cfg.data.hub_min_share, cover=True)
    found = len(hubs)
    while True:
        held = hub_locations(table, hubs, history)
        keep = [h for h, d in zip(hubs, held, strict=True) if d >= n_depots]
        if len(keep) == len(hubs):
            return hubs, found - len(hubs)
        if not keep:
            most = max(held)
            raise InputError(
                f"no hub placed over the history days holds the {n_depots} distinct customer "
                f"locations its {n_depots} depots need (the most any holds is {most:,}): "
                f"lower {option('n_depots')}, or plan one square with {option('area')} square",
                file=table.source.path,
            )
        hubs = [dataclasses.replace(h, id=i) for i, h in enumerate(keep)]


def with_fleets(
    hubs: Sequence[Hub], demand: Sequence[int], drones: int, city_drones: int | None = None
) -> list[Hub]:
    """The hubs with their fleets (docs/method.md §1.1): a hub that names its own keeps
    it; the others share the city's fleet by their ``demand`` (:func:`share_fleet`):
    ``city_drones`` less the hubs' own, else ``drones`` for each of them."""
    import dataclasses

    rest = [h for h in hubs if h.drones is None]
    if not rest:
        return list(hubs)
    if city_drones is None:
        city = drones * len(rest)
    else:
        city = city_drones - sum(h.drones for h in hubs if h.drones is not None)
    shares = iter(share_fleet([demand[h.id] for h in rest], city))
    return [
        h if h.drones is not None else dataclasses.replace(h, drones=next(shares)) for h in hubs
    ]


def share_fleet(demand: Sequence[int], drones: int) -> list[int]:
    """``drones`` shared out over hubs by their ``demand`` (docs/method.md §1.1): each hub
    one drone, the rest by largest remainder of its share of the demand (ties to the
    hub first in order); a city without demand shares evenly. Refused when there are
    fewer drones than hubs, or a hub would get more than :data:`MAX_DRONES`."""
    n = len(demand)
    if drones < n:
        raise InputError(
            f"{option('city_drones')} {drones} is fewer than the city's {n} hubs that share "
            "it: each hub flies one drone at least"
        )
    total = sum(demand)
    weights = np.asarray(demand, dtype=np.float64) if total > 0 else np.ones(n)
    quota = (drones - n) * weights / weights.sum()
    got = np.floor(quota).astype(np.int64)
    left = drones - n - int(got.sum())
    order = np.lexsort((np.arange(n), -(quota - got)))  # largest remainder, then hub order
    got[order[:left]] += 1
    fleet = [int(g) + 1 for g in got]
    if max(fleet) > MAX_DRONES:
        raise InputError(
            f"a city fleet of {drones} drones gives one hub {max(fleet)}, more than the "
            f"{MAX_DRONES} a study area plans for (docs/config.md): lower "
            f"{option('city_drones')}, or give that hub its drones in a hubs file"
        )
    return fleet
