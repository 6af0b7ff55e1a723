"""The status lines and warnings the use cases report (docs/method.md §1, docs/outputs.md):
one wording for the command line and the Python API."""

from __future__ import annotations

import datetime as dt
from typing import Any

from ..data.table import LadeTable
from .progress import Progress

UNDELIVERED_WARN = 0.10
"""Share of a day's requests left undelivered above which a run warns."""


def drop_report(progress: Progress, table: LadeTable, name: str) -> None:
    """Which rows were dropped and why (docs/method.md §1), and a warning when kept rows
    share an order id: each is planned as an order of its own, which an export's repeated
    upload with other times or positions would deliver twice."""
    progress.message(table.report.describe(name))
    ids = table.order_id
    repeated = len(ids) - len(set(ids.tolist()))
    if repeated:
        progress.warning(
            f"{name}: {repeated:,} kept {'row repeats' if repeated == 1 else 'rows repeat'} "
            "an earlier row's order_id with other times or positions; each is planned as "
            "an order of its own"
        )


def day_scope(progress: Progress, scope: Any, cfg: Any, label: str = "") -> None:
    """How many of the day's orders are planned and what the study area and the service
    hours left out (docs/method.md §1), from its ``sim.days.DayScope``; ``label`` names
    the hub of a city run."""
    left = []
    if scope.outside_area:
        left.append(f"{scope.outside_area:,} outside the {cfg.data.size_km:g} km study area")
    if scope.outside_hours:
        left.append(
            f"{scope.outside_hours:,} due outside service hours "
            f"{cfg.data.service_start}-{cfg.data.service_end}"
        )
    tail = f", {sum((scope.outside_area, scope.outside_hours)):,} left out ({'; '.join(left)})"
    progress.message(
        f"{label}{scope.day.isoformat()}: {scope.orders_due:,} orders due, "
        f"{scope.planned:,} planned" + (tail if left else "")
    )


def unservable_requests(
    progress: Progress, day: dt.date, reqs: Any, depots_xy: Any, models: list[Any]
) -> None:
    """Warn about a day's requests no drone of the fleet can serve at all (too heavy, too
    far), as a replayed day's metrics count them (``plan-window``)."""
    from ..sim.metrics import unservable

    heavy, far = unservable(reqs, depots_xy, models)
    if heavy or far:
        _unservable(progress, day.isoformat(), heavy, far)


def _unservable(progress: Progress, day: str, heavy: int, far: int, label: str = "") -> None:
    progress.warning(
        f"{label}{day}: {heavy:,} parcels heavier than the payload limit and "
        f"{far:,} requests beyond any drone's reach from the nearest depot cannot be served"
    )


def undelivered(progress: Progress, metrics: dict[str, Any], drones: int, label: str = "") -> None:
    """Warn when more than 10 % of a day's requests stayed undelivered, and about
    requests no drone can serve at all (too heavy, too far); ``label`` names the hub of
    a city run."""
    heavy, far = metrics.get("unservable_heavy", 0), metrics.get("unservable_far", 0)
    if heavy or far:
        _unservable(progress, str(metrics["day"]), heavy, far, label)
    share = metrics["undelivered"] / max(metrics["requests"], 1)
    if share > UNDELIVERED_WARN:
        progress.warning(
            f"{label}{metrics['day']}: {metrics['undelivered']:,} of {metrics['requests']:,} "
            f"requests ({share:.0%}) stayed undelivered with {drones} "
            + ("drone" if drones == 1 else "drones")
        )
