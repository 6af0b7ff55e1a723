"""``segment`` as one library call: place the study area over a LaDe table, segment it."""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass

import numpy as np

from ..config import PlannerConfig
from ..data.frame import Frame
from ..data.prepare import check_days_in_file, study_frame
from ..data.table import LadeTable
from ..errors import InputError, naming
from .depots import Depots
from .methods import segment_points


@dataclass
class SegmentResult:
    depots: Depots
    table: LadeTable
    days: list[dt.date]
    history_xy: np.ndarray  # (n, 2) customer points used, metres


def history_points(
    table: LadeTable, frame: Frame, days: list[dt.date] | None
) -> tuple[np.ndarray, list[dt.date]]:
    """Customer locations of the history days that fall inside the study square."""
    all_days = table.days()
    if days:
        check_days_in_file(table, days)
        mask = np.isin(table.delivery_day, np.array(days, dtype="datetime64[D]"))
    else:
        days = all_days
        mask = np.ones(len(table), dtype=bool)
    x, y = frame.to_xy(table.lng[mask], table.lat[mask])
    inside = frame.contains(x, y)
    if not inside.any():
        raise InputError(
            f"the study area ({frame.size_km:g} km square around {frame.center_lng:.5f}, "
            f"{frame.center_lat:.5f}) holds no requests on the chosen days; place it over "
            "them with --center (or [data] center) and --size-km",
            file=table.source.path,
        )
    return np.column_stack([x[inside], y[inside]]), days


def segment_table(
    table: LadeTable, cfg: PlannerConfig, days: list[dt.date] | None = None
) -> SegmentResult:
    """Depots and service areas for the rows of ``table`` due on ``days`` (all when None)."""
    check_days_in_file(table, days or [])  # every row dropped: says why, with or without days
    frame = study_frame(table, cfg.data, days or None)
    pts, used_days = history_points(table, frame, days)
    try:
        depots = segment_points(pts[:, 0], pts[:, 1], frame, cfg.segment)
    except InputError as exc:
        raise naming(exc, table.source.path) from None
    return SegmentResult(depots, table, used_days, pts)
