"""The status lines and warnings the use cases report (docs/method.md §1, docs/outputs.md):
one wording for the command line and the Python API."""

from __future__ import annotations

import datetime as dt
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..data.table import LadeTable
from .progress import Progress

UNDELIVERED_WARN = 0.10
"""Share of a day's requests left undelivered above which a run warns."""


def drop_report(progress: Progress, table: LadeTable, name: str) -> None:
    """Which rows were dropped and why (docs/method.md §1), and a warning when kept rows
    share an order id: each is planned as an order of its own, which an export's repeated
    upload with other times or positions would deliver twice."""
    progress.message(table.report.describe(name))
    if (wrap := new_year_warning(table.days(), name)) is not None:
        progress.warning(wrap)
    if (grams := grams_warning(table.weight_kg, name)) is not None:
        progress.warning(grams)
    ids = table.order_id
    repeated = len(ids) - len(set(ids.tolist()))
    if repeated:
        progress.warning(
            f"{name}: {repeated:,} kept {'row repeats' if repeated == 1 else 'rows repeat'} "
            "an earlier row's order_id with other times or positions; each is planned as "
            "an order of its own"
        )


NEW_YEAR_GAP_DAYS = 183
"""Days between an export's January and its December beyond which it looks like one that
runs over the new year, read with one year."""


def new_year_warning(days: list[dt.date], name: str) -> str | None:
    """A warning when the file's due ``days``, all in one year, hold January and December
    with more than :data:`NEW_YEAR_GAP_DAYS` days between: an export over the new year
    written with ``MM-DD`` times, which take one year (``--year``), so its January days
    come before its December and an order accepted on 31 December and delivered on 1
    January reads as delivered before it was accepted."""
    if len(days) < 2 or days[0].year != days[-1].year:
        return None
    if days[0].month != 1 or days[-1].month != 12:
        return None
    gap = max(b - a for a, b in zip(days, days[1:], strict=False))
    if gap.days <= NEW_YEAR_GAP_DAYS:
        return None
    from ..data.dates import format_days
    from ..errors import option

    year = days[0].year
    return (
        f"{name}: its days are {format_days(days)}, {gap.days - 1} days without orders "
        f"between: if the export runs over the new year, MM-DD times take one "
        f"year ({option('year')} {year}), so its January days are read as January {year}, "
        f"before its December, and an order accepted in December and delivered in January "
        f"as delivered before it was accepted (dropped); write its times as "
        f"YYYY-MM-DD HH:MM:SS"
    )


GRAMS_MEDIAN_KG = 100.0
"""A file's median ``weight_kg`` above which its weights look like grams: no parcel
export's typical parcel weighs 100 kg, while grams put a 0.5 kg parcel at 500."""


def grams_warning(weight_kg: np.ndarray | None, name: str) -> str | None:
    """A warning when the file's ``weight_kg`` column has a median above
    :data:`GRAMS_MEDIAN_KG`: weights written in grams, each parcel then 1,000 times too
    heavy for any drone, which the run would say only hub by hub as parcels heavier than
    the payload limit."""
    if weight_kg is None or not len(weight_kg):
        return None
    median = float(np.median(weight_kg))
    if median <= GRAMS_MEDIAN_KG:
        return None
    return (
        f"{name}: its weight_kg column's median parcel weighs {median:,.0f} kg: weights are "
        "read in kg; if the column holds grams, divide it by 1,000"
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


FEW_DAYS = 3
"""Replayed days (hub-days) whose warnings a run says each in a line of its own; more
are said in one line (a city run over many hubs and days)."""


def undelivered(progress: Progress, days: Sequence[tuple[dict[str, Any], int, str]]) -> None:
    """Warn about the replayed ``days`` (each its metrics, drones and hub label) that left
    more than 10 % of their requests undelivered, and about requests no drone can serve
    at all (too heavy, too far): a line for each of a few days, one line for many, which
    names the worst (each day's counts are in its metrics.json)."""
    unit = "hub-days" if any(label for _, _, label in days) else "days"
    cut = [d for d in days if d[0].get("unservable_heavy", 0) or d[0].get("unservable_far", 0)]
    if len(cut) <= FEW_DAYS:
        for m, _, label in cut:
            heavy, far = m.get("unservable_heavy", 0), m.get("unservable_far", 0)
            _unservable(progress, str(m["day"]), heavy, far, label)
    else:
        heavy = sum(m.get("unservable_heavy", 0) for m, _, _ in cut)
        far = sum(m.get("unservable_far", 0) for m, _, _ in cut)
        progress.warning(
            f"{len(cut):,} of {len(days):,} {unit}: {heavy:,} parcels heavier than the "
            f"payload limit and {far:,} requests beyond any drone's reach from the nearest "
            "depot cannot be served, in all; each day's metrics (metrics.json) count them "
            "(unservable_heavy, unservable_far)"
        )
    short = [d for d in days if _short(d[0]) > UNDELIVERED_WARN]
    if len(short) <= FEW_DAYS:
        for m, drones, label in short:
            progress.warning(
                f"{label}{m['day']}: {m['undelivered']:,} of {m['requests']:,} requests "
                f"({_short(m):.0%}) stayed undelivered with {_drones(drones)}"
            )
        return
    worst = ", ".join(
        f"{label}{m['day']} ({_short(m):.0%} of {m['requests']:,}, with {_drones(drones)})"
        for m, drones, label in sorted(short, key=lambda d: -_short(d[0]))[:FEW_DAYS]
    )
    progress.warning(
        f"{len(short):,} of {len(days):,} {unit}: more than {UNDELIVERED_WARN:.0%} of their "
        f"requests stayed undelivered, the most {worst}; each day's metrics (metrics.json) "
        "count them (undelivered, requests)"
    )


def _short(metrics: dict[str, Any]) -> float:
    """The share of a day's requests that stayed undelivered."""
    return float(metrics["undelivered"] / max(metrics["requests"], 1))


def _drones(drones: int) -> str:
    return f"{drones} drone" if drones == 1 else f"{drones} drones"


def long_flights(progress: Progress, types: Sequence[Any], cfg: Any) -> None:
    """Warn, under ``busy = false`` (every flight ends in its window: the paper's model),
    about the drone ``types`` (:class:`~marops_cli.sim.fleet.DroneType`) whose battery
    lasts longer than a window: a route of one of them may outlast its window while its
    drone is planned again in the next (docs/method.md, "Busy drones")."""
    if cfg.ops.busy:
        return
    window_s = cfg.data.window_s
    said: set[str] = set()
    for t in types:
        flight_s = longest_flight_s(t.model)
        if flight_s > window_s and t.name not in said:
            said.add(t.name)
            progress.warning(
                f"the fleet's drone type {t.name!r} flies up to {_duration(flight_s)} on a "
                f"battery, longer than the {_duration(window_s, '-')} window: under busy = false "
                "its drone is planned again in the next window while its flight may go on "
                "(busy = true keeps it until it lands)"
            )


def longest_flight_s(model: Any) -> float:
    """Seconds the usable battery of ``model`` (an EnergyModel) keeps its drone in the air
    at the least power it flies at (empty): the longest flight a route can be."""
    return float(model.usable_j / float(np.min(model.table_w)))


def _duration(seconds: float, sep: str = " ") -> str:
    """``2.2 h`` or ``30 min`` (``sep``: what goes between, ``-`` before a noun)."""
    return f"{seconds / 3600:.1f}{sep}h" if seconds >= 5400 else f"{seconds / 60:.0f}{sep}min"


def late_orders(
    progress: Progress, table: LadeTable, days: Sequence[dt.date], cfg: Any, held: np.ndarray
) -> None:
    """Warn when most orders due on ``days`` are due outside service hours
    (:func:`~marops_cli.data.prepare.late_warning`; ``held``: the rows the run plans
    from, a hub's or the square's)."""
    from ..data.prepare import late_warning

    late = late_warning(table, days, cfg.data, held=held)
    if late is not None:
        progress.warning(late)
