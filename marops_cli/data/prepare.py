"""From a read export to planning input: study area, windows and weights (docs/method.md §1).

- :func:`study_frame` places the study area: ``cfg.center`` if set, else the
  densest ``size_km`` square of the chosen days' customers.
- :func:`prepare_day` keeps the requests due on one day inside that square and
  within service hours, and puts each in its windows. Service hours are
  half-open: a delivery at exactly 17:00:00 is outside 09:00–17:00.
- :func:`parcel_weights` draws the weights LaDe lacks, from the order id alone.
"""

from __future__ import annotations

import datetime as dt
import hashlib
from collections.abc import Iterable

import numpy as np
from scipy.special import ndtri

from ..errors import InputError, naming, switch
from .dates import day_index, day_offsets, format_days, instants
from .frame import Frame, densest_square
from .settings import DataSettings
from .table import DayRequests, LadeTable

_DAY_S = 86_400


def parcel_weights(order_ids: Iterable[object], cfg: DataSettings) -> np.ndarray:
    """One weight in kg per order id, the same for that id in every run and process.

    The id's UTF-8 text is hashed with BLAKE2b (Python's ``hash()`` is salted per
    process); the 64-bit digest is a uniform draw in (0, 1) that the inverse normal
    CDF turns into a standard normal ``z``. The weight is
    ``median * exp(sigma * z)`` -- lognormal with that median and sigma -- clipped
    to ``[weight_min_kg, weight_max_kg]``.
    """
    ids = [str(o) for o in np.asarray(order_ids, dtype=object).ravel()]
    if not ids:
        return np.zeros(0, dtype=np.float64)
    raw = b"".join(hashlib.blake2b(i.encode("utf-8"), digest_size=8).digest() for i in ids)
    h = np.frombuffer(raw, dtype="<u8")
    # Top 53 bits plus half a step: uniform in the open interval (0, 1), never 0 or 1.
    u = ((h >> np.uint64(11)).astype(np.float64) + 0.5) / float(1 << 53)
    z = ndtri(u)
    w = cfg.weight_median_kg * np.exp(cfg.weight_sigma * z)
    return np.clip(w, cfg.weight_min_kg, cfg.weight_max_kg)


def check_days_in_file(table: LadeTable, days: Iterable[dt.date]) -> None:
    """Raise :class:`InputError` naming the first of ``days`` the file has no request due on."""
    have = table.days()
    present = set(have)
    rep = table.report
    if not have and rep.total:  # every row was dropped: say why, not which day is missing
        raise InputError(
            f"none of its {rep.total:,} rows can be used ({rep.reasons()}); {switch('strict')} "
            "names the first",
            file=table.source.path,
        )
    from .reader import IN_MEMORY

    # Rows in memory are called what they are (the DataFrame, the Table), as elsewhere.
    held = f"the {table.source.path}" if table.source.path in IN_MEMORY else "the file"
    for day in days:
        if day not in present:
            # A day given without its year (0101) takes --year; the file's may be another.
            same = [d for d in have if (d.month, d.day) == (day.month, day.day)]
            hint = (
                f"; its {day:%m-%d} is {same[0].isoformat()}: give the date in full" if same else ""
            )
            if not same and have and have[0] < day < have[-1]:  # a gap the list may not reach
                before = max(d for d in have if d < day)
                after = min(d for d in have if d > day)
                hint = f"; the nearest days it has are {before} and {after}"
            raise InputError(
                f"date {day.isoformat()} not in {held} (it has {format_days(have)}{hint})",
                file=table.source.path,
                column="delivery_time",
            )


def due_on(table: LadeTable, days: Iterable[dt.date]) -> np.ndarray:
    """Mask of rows due on any of ``days``."""
    wanted = np.array([np.datetime64(d, "D") for d in days], dtype="datetime64[D]")
    return np.isin(table.delivery_day, wanted)


def study_frame(
    table: LadeTable, cfg: DataSettings, days: Iterable[dt.date] | None = None
) -> Frame:
    """The study area: ``cfg.center`` if given, else the densest square of the customers
    due on ``days`` (every day in the file when None), on a ``cfg.grid_m`` grid."""
    if cfg.center is not None:
        return Frame(float(cfg.center[0]), float(cfg.center[1]), cfg.size_km)
    if days is None:
        lng, lat = table.lng, table.lat
    else:
        days = list(days)
        check_days_in_file(table, days)
        mask = due_on(table, days)
        lng, lat = table.lng[mask], table.lat[mask]
    if lng.size == 0:
        raise InputError("no requests to place a study area on", file=table.source.path)
    try:
        return densest_square(lng, lat, cfg.size_km, cfg.grid_m)
    except InputError as exc:
        raise naming(exc, table.source.path) from None


def _windows(offset_s: np.ndarray, window_s: float, n_windows: int) -> np.ndarray:
    """Window index of each offset from service start, clamped to [0, n_windows - 1]."""
    return np.clip(np.floor(offset_s / window_s), 0, n_windows - 1).astype(np.int32)


def _visible_windows(accept_s: np.ndarray, due_w: np.ndarray, cfg: DataSettings) -> np.ndarray:
    """The window each request becomes visible in: its accept time's, never after its due
    window (accept <= delivery after reading but in the hour a clock goes back, where
    zone-aware times are checked in absolute time, and the clamping)."""
    return np.minimum(_windows(accept_s, cfg.window_s, cfg.n_windows), due_w)


def _since_start(table: LadeTable, cfg: DataSettings) -> tuple[np.ndarray, np.ndarray]:
    """``(start, due)`` per row: the instant (s, UTC) service starts on its delivery day,
    and its delivery time from that start in elapsed seconds. Windows are elapsed time
    from the start (docs/decisions.md, "Study area, windows"): on a day the clocks
    change, every window is still ``window_s`` long and none starts where another did."""
    days, which = day_index(table.delivery_day)
    wall = days * _DAY_S + cfg.service_start_s
    start = instants(wall, cfg.tz)
    if table.delivery_at is None and day_offsets(days, cfg.tz)[1].all():
        # No clock change on any of its days: elapsed time is wall-clock time.
        return start[which], table.delivery_s - wall[which]
    at = table.delivery_at if table.delivery_at is not None else instants(table.delivery_s, cfg.tz)
    return start[which], at - start[which]


def _in_service(
    table: LadeTable, frame: Frame, on: np.ndarray, cfg: DataSettings
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(start, due, x, y, inside, keep)`` per row: the service start (s, UTC) of its
    delivery day, its delivery time from that start, its position in ``frame``, whether
    it is on ``on`` and in the frame, and whether it is also due within service hours."""
    start, since = _since_start(table, cfg)
    due = since.astype(np.float64)
    x, y = frame.to_xy(table.lng, table.lat)
    inside = on & frame.contains(x, y)
    return start, due, x, y, inside, inside & (due >= 0) & (due < cfg.span_s)


def _accepted(
    table: LadeTable, rows: np.ndarray, start: np.ndarray, cfg: DataSettings
) -> np.ndarray:
    """The accept times of ``table``'s ``rows`` (a mask) from their day's service start
    (``start``, s UTC, of those rows), in elapsed seconds."""
    if table.accept_at is not None:
        at = table.accept_at[rows]
    else:
        at = instants(table.accept_s[rows], cfg.tz)
    return (at - start).astype(np.float64)


def in_service_hours(table: LadeTable, cfg: DataSettings) -> np.ndarray:
    """Per row: whether it is due within its day's service hours (as :func:`prepare_day`
    keeps it)."""
    due = _since_start(table, cfg)[1]
    return (due >= 0) & (due < cfg.span_s)


LATE_WARNING = 0.5
"""The share of the orders due that, due outside service hours, a run warns of."""


def _clock(s: float) -> str:
    """Seconds into a day as ``HH:MM``."""
    m = int(s) % 86_400 // 60
    return f"{m // 60:02d}:{m % 60:02d}"


def _hours(cfg: DataSettings) -> str:
    """The service hours as ``09:00-17:00``."""
    return f"{_clock(cfg.service_start_s)}-{_clock(cfg.service_start_s + cfg.span_s)}"


def late_warning(
    table: LadeTable, days: Iterable[dt.date], cfg: DataSettings, held: np.ndarray | None = None
) -> str | None:
    """A warning when at least :data:`LATE_WARNING` of the orders due on ``days`` are due
    outside service hours (times of another zone than ``cfg.tz``, a UTC export): the run
    leaves them out, and its city line alone would show it. It names the clock times
    the middle half of the orders are due between, the zone and the settings to give.
    ``held``: the rows a hub holds (the others are left out as outside every hub, and
    counted so), when the run plans hubs."""
    due = due_on(table, list(days))
    total = int(due.sum())
    late_rows = due & ~in_service_hours(table, cfg)
    late = int((late_rows if held is None else late_rows & held).sum())
    if not total or late < LATE_WARNING * total:
        return None
    lo, hi = np.percentile(np.mod(table.delivery_s[due], 86_400), [25, 75])
    return (
        f"{late:,} of the {total:,} orders due ({late / total:.0%}) are due outside service "
        f"hours {_hours(cfg)}, and are left out; the middle "
        f"half of all is due between {_clock(lo)} and {_clock(hi)}: if the file's times are "
        f"of another zone than {cfg.tz}, write each with its offset (+00:00), read as the "
        "instant it names, else set [data] service_start and service_end"
    )


def late_note(table: LadeTable, day: dt.date, held: np.ndarray, cfg: DataSettings) -> str:
    """Why no hub plans ``day`` when its orders in a hub's square (``held``) are all due
    outside service hours (``: its 160 orders inside a hub's square are all due outside
    09:00-17:00``), else ``""``."""
    late = int((due_on(table, [day]) & held & ~in_service_hours(table, cfg)).sum())
    if not late:
        return ""
    if late == 1:
        return f": its one order inside a hub's square is due outside {_hours(cfg)}"
    return f": its {late:,} orders inside a hub's square are all due outside {_hours(cfg)}"


def prepare_day(table: LadeTable, frame: Frame, day: dt.date, cfg: DataSettings) -> DayRequests:
    """The requests due on ``day`` inside ``frame`` and within service hours.

    ``visible_w`` is the window holding the accept time (0 when accepted before
    service start or on an earlier day); ``due_w`` the window holding the
    delivery time. Weights come from the file's ``weight_kg`` when present, else
    :func:`parcel_weights`. Requests are sorted by due time, then order id, then
    file row. Raises :class:`InputError` when the day is not in the file or
    nothing is left.
    """
    on_day = due_on(table, [day])
    if not on_day.any():
        check_days_in_file(table, [day])  # raises, naming the days the file has
    start, due, x, y, inside, mask = _in_service(table, frame, on_day, cfg)
    if not mask.any():
        raise InputError(
            f"no requests on {day.isoformat()} inside the study area "
            f"({frame.size_km:g} km square around {frame.center_lng:.5f}, "
            f"{frame.center_lat:.5f}) due within service hours "
            f"{cfg.service_start}-{cfg.service_end}",
            file=table.source.path,
        )
    sub = table.subset(mask)
    due, x, y = due[mask], x[mask], y[mask]
    accept = _accepted(table, mask, start[mask], cfg)
    # Stable sorts, last key first: due time, then order id, then file order.
    order = np.argsort(sub.order_id, kind="stable")
    order = order[np.argsort(due[order], kind="stable")]
    weight = sub.weight_kg if sub.weight_kg is not None else parcel_weights(sub.order_id, cfg)
    due_w = _windows(due, cfg.window_s, cfg.n_windows)
    visible_w = _visible_windows(accept, due_w, cfg)
    return DayRequests(
        day=day,
        frame=frame,
        service_start_s=cfg.service_start_s,
        tz=cfg.tz,
        window_s=cfg.window_s,
        n_windows=cfg.n_windows,
        order_id=sub.order_id[order],
        x_m=x[order],
        y_m=y[order],
        lng=sub.lng[order],
        lat=sub.lat[order],
        weight_kg=np.asarray(weight, dtype=np.float64)[order],
        visible_w=visible_w[order],
        due_w=due_w[order],
        due_s=due[order],
        accept_s=accept[order],
        outside_area=int((on_day & ~inside).sum()),
        outside_hours=int((inside & ~mask).sum()),
    )


def arrival_windows(
    table: LadeTable, frame: Frame, days: Iterable[dt.date], cfg: DataSettings
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(x, y, visible_w)`` of every request :func:`prepare_day` would keep on ``days``,
    all days at once: where and in which window each became visible (the window of its
    accept time, 0 when accepted before service start)."""
    start, due, x, y, _, keep = _in_service(table, frame, due_on(table, list(days)), cfg)
    due_w = _windows(due[keep], cfg.window_s, cfg.n_windows)
    accept = _accepted(table, keep, start[keep], cfg)
    return x[keep], y[keep], _visible_windows(accept, due_w, cfg)


def prepare_days(
    table: LadeTable, days: Iterable[dt.date], cfg: DataSettings
) -> tuple[Frame, list[DayRequests]]:
    """The study area over ``days`` and each day prepared in it, in the order given."""
    days = list(days)
    frame = study_frame(table, cfg, days)
    return frame, [prepare_day(table, frame, d, cfg) for d in days]
