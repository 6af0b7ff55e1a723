"""In-memory forms of LaDe data: the cleaned export and one prepared day."""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass, field

import numpy as np

from .frame import Frame

# Columns of a LaDe-D delivery export, in file order (docs/method.md §1).
LADE_COLUMNS: tuple[str, ...] = (
    "order_id",
    "region_id",
    "city",
    "courier_id",
    "lng",
    "lat",
    "aoi_id",
    "aoi_type",
    "accept_time",
    "accept_gps_time",
    "accept_gps_lng",
    "accept_gps_lat",
    "delivery_time",
    "delivery_gps_time",
    "delivery_gps_lng",
    "delivery_gps_lat",
    "ds",
)
# The columns the planner cannot do without. ``ds`` is checked when present but not
# needed: a request's day is the date of its delivery time.
REQUIRED_COLUMNS: tuple[str, ...] = ("order_id", "lng", "lat", "accept_time", "delivery_time")

# Reasons a row is dropped (reported to the user; ``--strict`` makes them errors).
DROP_REASONS: tuple[str, ...] = (
    "bad_coordinates",  # lng/lat empty, outside [-180, 180] x [-90, 90], or 0 as a mark
    "duplicate",  # a repeat of an earlier row (same order_id and times)
    "delivery_before_accept",
    "missing_time",  # accept_time or delivery_time empty (or NULL, \N, NaN, None, --)
    "malformed_row",  # a CSV line of another number of fields than the header (cut short)
    "repeated_header",  # the header line again (two exports written one after the other)
)


@dataclass(frozen=True)
class SourceInfo:
    """Identity of an input file, recorded in every output's metadata."""

    path: str
    name: str
    size: int
    sha256: str

    def to_dict(self) -> dict[str, object]:
        return {"name": self.name, "size": self.size, "sha256": self.sha256}


@dataclass
class DropReport:
    """Every row accounted for: ``total == kept + sum(dropped.values())``."""

    total: int
    kept: int
    dropped: dict[str, int] = field(default_factory=dict)
    ds_other_day: int = 0
    """Kept rows whose ``ds`` names another day than their delivery time: a note, not a
    drop (a request's day is the date of its delivery time)."""
    swapped_coordinates: int = 0
    """Rows dropped for bad coordinates that would be good with lng and lat swapped."""
    over_new_year: int = 0
    """Rows dropped as delivered before accepted that were accepted in December and
    delivered in January of one year: ``MM-DD`` times of an export over the new year."""
    decimal_comma: int = 0
    """Rows dropped for bad coordinates written with a decimal comma (``121,47``)."""

    @property
    def n_dropped(self) -> int:
        return int(sum(self.dropped.values()))

    def to_dict(self) -> dict[str, object]:
        doc: dict[str, object] = {
            "total": self.total,
            "kept": self.kept,
            "dropped": dict(self.dropped),
        }
        if self.ds_other_day:
            doc["ds_other_day"] = self.ds_other_day
        if self.swapped_coordinates:
            doc["swapped_coordinates"] = self.swapped_coordinates
        if self.over_new_year:
            doc["over_new_year"] = self.over_new_year
        if self.decimal_comma:
            doc["decimal_comma"] = self.decimal_comma
        return doc

    def reasons(self) -> str:
        """The rows dropped for each reason, in words (``73 bad coordinates, 120
        duplicate``)."""
        notes = [
            (
                "bad_coordinates",
                self.swapped_coordinates,
                "good with lng and lat swapped: are the columns swapped?",
            ),
            (
                "bad_coordinates",
                self.decimal_comma,
                "written with a decimal comma: write the numbers with a decimal point",
            ),
            (
                "delivery_before_accept",
                self.over_new_year,
                "accepted in December, delivered in January of one year: if the export runs "
                "over the new year, write its times as YYYY-MM-DD HH:MM:SS",
            ),
        ]
        parts = []
        for reason, n in self.dropped.items():
            if not n:
                continue
            part = f"{n:,} {reason.replace('_', ' ')}"
            said = [
                f"{'all' if k == n else f'{k:,}'} {why}" for r, k, why in notes if r == reason and k
            ]
            parts.append(f"{part} ({'; '.join(said)})" if said else part)
        return ", ".join(parts)

    def describe(self, name: str) -> str:
        """What was read from the file ``name`` and which rows were dropped and why
        (docs/method.md §1), as one line for the user."""
        note = (
            f"; {self.ds_other_day:,} kept {'row has' if self.ds_other_day == 1 else 'rows have'}"
            " a ds of another day than the delivery time, whose day is used"
            if self.ds_other_day
            else ""
        )
        if self.n_dropped == 0:
            return f"{name}: {self.total:,} rows read, none dropped{note}"
        parts = self.reasons()
        return (
            f"{name}: {self.total:,} rows read, {self.kept:,} kept, "
            f"{self.n_dropped:,} dropped ({parts}); --strict makes these errors{note}"
        )


@dataclass
class LadeTable:
    """The kept rows of a LaDe export as numpy arrays, in file order.

    Times are naive local seconds since 1970-01-01 (the export has no zone).
    ``row`` is each request's 1-based row in the source file (header = row 1).
    """

    order_id: np.ndarray  # object array of str
    lng: np.ndarray  # float64
    lat: np.ndarray  # float64
    accept_s: np.ndarray  # int64
    delivery_s: np.ndarray  # int64
    aoi_id: np.ndarray  # object array of str ("" when absent)
    weight_kg: np.ndarray | None  # float64 when the file has weight_kg
    row: np.ndarray  # int64
    source: SourceInfo
    report: DropReport
    accept_at: np.ndarray | None = None
    """The instants (s since 1970-01-01 UTC) of ``accept_s`` where the file gave times
    with their zone (exact where a row's did, from the wall clock in the data's zone
    where not); None when no row did (:func:`marops_cli.data.dates.instants` of the
    wall clock)."""
    delivery_at: np.ndarray | None = None
    """The same for ``delivery_s``."""

    def __len__(self) -> int:
        return int(self.order_id.shape[0])

    @property
    def delivery_day(self) -> np.ndarray:
        """Date (datetime64[D]) of each request's delivery time: the day it is due."""
        return (self.delivery_s // 86_400).astype("datetime64[D]")

    def days(self) -> list[dt.date]:
        """Sorted distinct due days in the file."""
        return [d.item() for d in np.unique(self.delivery_day)]

    def subset(self, mask: np.ndarray) -> LadeTable:
        """Rows where ``mask`` holds (the report is kept as is)."""
        return LadeTable(
            order_id=self.order_id[mask],
            lng=self.lng[mask],
            lat=self.lat[mask],
            accept_s=self.accept_s[mask],
            delivery_s=self.delivery_s[mask],
            aoi_id=self.aoi_id[mask],
            weight_kg=None if self.weight_kg is None else self.weight_kg[mask],
            row=self.row[mask],
            source=self.source,
            report=self.report,
            accept_at=None if self.accept_at is None else self.accept_at[mask],
            delivery_at=None if self.delivery_at is None else self.delivery_at[mask],
        )


@dataclass
class DayRequests:
    """The requests due on one day inside the study area, ready for planning.

    Windows are 0-based over service hours; ``visible_w`` <= ``due_w`` always.
    ``due_s`` and ``accept_s`` are seconds from the start of service hours, elapsed
    time (on a day the clocks change as on any other: docs/decisions.md, "Study area,
    windows"); ``tz`` is the zone of the data's wall clock.
    """

    day: dt.date
    frame: Frame
    service_start_s: int  # seconds after midnight
    window_s: float
    n_windows: int
    order_id: np.ndarray  # object array of str
    x_m: np.ndarray
    y_m: np.ndarray
    lng: np.ndarray
    lat: np.ndarray
    weight_kg: np.ndarray
    visible_w: np.ndarray  # int32
    due_w: np.ndarray  # int32
    due_s: np.ndarray  # float64
    accept_s: np.ndarray  # float64 (negative when accepted before service start)
    outside_area: int = 0  # orders due that day left out: outside the study square
    outside_hours: int = 0  # ... inside it but due outside service hours
    tz: str = "Asia/Shanghai"  # the data's zone (LaDe's times are Shanghai local time)

    @property
    def orders_due(self) -> int:
        """Orders of the file due that day (after bad rows were dropped)."""
        return len(self) + self.outside_area + self.outside_hours

    def __len__(self) -> int:
        return int(self.order_id.shape[0])

    @property
    def window_hours(self) -> float:
        return self.window_s / 3600.0

    def window_start(self, w: int) -> dt.datetime:
        """The start of window ``w`` on the wall clock of ``tz`` (naive: for display;
        :meth:`window_instant` is the instant)."""
        return self.window_instant(w).replace(tzinfo=None)

    def window_instant(self, w: int) -> dt.datetime:
        """The start of window ``w`` as a time of ``tz`` (zone-aware): service start on
        the day, then ``w`` windows of elapsed time, so on a day the clocks change no
        window starts where another did (a repeated wall-clock time has its ``fold``)."""
        from zoneinfo import ZoneInfo

        from .dates import instants

        wall = (self.day - dt.date(1970, 1, 1)).days * 86_400 + self.service_start_s
        start = int(instants(np.array([wall]), self.tz)[0])
        utc = dt.datetime(1970, 1, 1, tzinfo=dt.UTC) + dt.timedelta(seconds=start)
        return (utc + dt.timedelta(seconds=w * self.window_s)).astimezone(ZoneInfo(self.tz))
