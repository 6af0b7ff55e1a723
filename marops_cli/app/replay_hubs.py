"""Replaying every hub of a city (docs/method.md §1.1) and the city's coverage."""

from __future__ import annotations

import datetime as dt
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from ..config import count
from ..errors import InputError, in_hub
from ..io import folder_lock, output_set, run_meta
from ..io.meta import file_sha256
from .inputs import data_name, in_memory, read_data
from .messages import drop_report, late_orders
from .progress import Progress
from .replay_areas import ReplayResult, Run, aggregate_days, make_area, replay_areas


def replay_hubs(
    data: Any,
    hubs_path: Path | None,
    out: Path | None,
    days: list[dt.date],
    several: bool,
    cfg: Any,
    fleet: Any,
    run: Run,
    progress: Progress,
) -> ReplayResult:
    """Replay every hub of a hubs file, or (``hubs_path`` None) of hubs placed over the
    whole export: each a study area with its own depots and share of the fleet, into
    ``out/hub-<id>/``, and the city's coverage into ``out/metrics.json``."""
    from ..data.prepare import check_days_in_file
    from ..segment.hubs import hub_areas, hub_owner, hubs_history, load_hubs
    from ..sim.scenario import load_scenario

    table = read_data(data, cfg.data)
    check_days_in_file(table, days)
    history = hubs_history(table, days)
    unplaced = 0  # squares placed over the history, left out for too few locations
    if hubs_path is None:
        from ..segment.hubs import place_hubs

        hub_list, unplaced = place_hubs(table, cfg, history, cfg.segment.n_depots)
    else:
        hub_list = load_hubs(hubs_path, cfg.data)
    owner = hub_owner(table, hub_list)  # once: the hubs' squares are set from here on
    far = None
    if hubs_path is None:
        from ..segment.hubs import outside_warning

        far = outside_warning(
            table,
            hub_list,
            days,
            cfg.data.hub_min_share,
            owner,
            history=history,
            unplaced=unplaced,
            n_depots=cfg.segment.n_depots,
        )
    hub_list = city_fleet(table, hub_list, history, cfg, owner)
    hub_days = hub_areas(table, cfg, hub_list, days, owner)  # every hub-day checked first
    planned = {d for a in hub_days for d in a.days}
    empty = [d for d in days if d not in planned]
    if empty:  # as one square's run refuses a day with nothing to plan, before any work
        raise InputError(
            f"no requests on {empty[0].isoformat()} inside any hub's square due within "
            "service hours" + _why_empty(table, empty[0], owner, cfg, far),
            file=table.source.path,
        )
    areas = []
    skipped: list[str] = []
    for a in hub_days:
        skipped += [
            f"hub {a.hub.id}: no requests on {day.isoformat()} in its square, skipped"
            for day in a.skipped
        ]
        if not a.days:
            continue
        try:
            scn = load_scenario(
                table.source.path,
                a.cfg,
                replay_days=a.replayable(days),
                table=a.table,
                hub=a.hub.id,
                cache=not in_memory(data),
            )
        except InputError as exc:  # a hub too sparse for its depots: which one
            raise in_hub(exc, a.hub.id) from None
        folder = out / f"hub-{a.hub.id}" if out is not None else None
        area = make_area(scn, folder, a.days, several, fleet, run, None, f"hub {a.hub.id}: ")
        area.report_top = out  # the city's pages share one plotly.js (docs/report.md)
        if out is not None:  # the city's summary claims every hub's days
            area.summaries += [out / "metrics.json", out / "left_out.csv", out / "report.html"]
        areas.append(area)
    # Said once every hub's fleet and folder passed: an error is a failed run's only line.
    drop_report(progress, table, data_name(data))
    if far is not None:
        progress.warning(far)
    late_orders(progress, table, days, cfg, owner >= 0)
    for line in skipped:
        progress.message(line)
    with ExitStack() as held:
        if out is not None:  # the city's folder is the run's, with every hub's below it
            held.enter_context(folder_lock(out))
        per_area, tables = replay_areas(areas, run, progress)
        written = [f for a in areas for f in a.written]
        all_metrics = [m for rows in per_area for m in rows]
        left = left_out(table, days, owner, cfg)  # once: the city's figures and its list
        city = city_coverage(table, days, all_metrics, hub_list, left)
        total = aggregate_days(all_metrics)
        if out is not None:
            meta = run_meta(
                command="replay-day", config=cfg, source=table.source, method=run.method
            )
            if hubs_path is not None:
                meta["hubs_file"] = {"name": hubs_path.name, "sha256": file_sha256(hubs_path)}
            else:
                meta["hubs"] = [
                    {
                        "id": h.id,
                        "center_lng": h.frame.center_lng,
                        "center_lat": h.frame.center_lat,
                        "size_km": h.frame.size_km,
                        "drones": h.drones,
                    }
                    for h in hub_list
                ]
            left_path = out / "left_out.csv"
            with output_set() as files:
                files.write_json(
                    out / "metrics.json",
                    {"meta": meta, "city": city, "days": all_metrics, "total": total},
                )
                # Always, its header alone when nothing was left out: never an earlier
                # run's list beside this run's metrics.
                text = left_out_csv(table, left)
                files.write_bytes(left_path, text.encode("utf-8", "backslashreplace"))
            written += [out / "metrics.json", left_path]
            if run.report:  # the city's page; each hub's was written with its days
                from ..report import write_reports

                written += write_reports(out, below=False, shared=out)
    progress.message(city_line(city, len(hub_list)))
    return ReplayResult(all_metrics, total, tables, city, out, written)


def city_fleet(
    table: Any, hubs: list[Any], history: list[dt.date], cfg: Any, owner: Any
) -> list[Any]:
    """The hubs with their fleets: their own, or a share of the city's (``[sim]
    city_drones``, else ``drones`` each) by their demand on the history days (``owner``:
    each row's hub, :func:`~marops_cli.segment.hubs.hub_owner`)."""
    from ..segment.hubs import hub_demand, with_fleets

    demand = hub_demand(table, hubs, history, owner)
    return with_fleets(hubs, demand, cfg.sim.drones, cfg.sim.city_drones)


def _why_empty(table: Any, day: dt.date, owner: Any, cfg: Any, far: str | None) -> str:
    """Why no hub plans ``day``: its orders in a hub's square are all due outside service
    hours, or (none in a square) the run's warning of orders outside every hub, ``far``."""
    from ..data.prepare import late_note

    note = late_note(table, day, owner >= 0, cfg.data)
    if note:
        return note
    return f": {far}" if far is not None else ""


def left_out(table: Any, days: list[dt.date], owner: Any, cfg: Any) -> tuple[Any, Any]:
    """Rows due on ``days`` and not planned: (mask, reason per row) — outside every hub
    (``owner``: each row's hub, :func:`~marops_cli.segment.hubs.hub_owner`), or in a hub
    and due outside service hours."""
    import numpy as np

    from ..data.prepare import due_on, in_service_hours

    due = due_on(table, days)
    hours = in_service_hours(table, cfg.data)
    outside = due & (owner < 0)
    late = due & (owner >= 0) & ~hours
    reason = np.where(outside, "outside every hub", "outside service hours")
    return outside | late, reason


def left_out_csv(table: Any, left: tuple[Any, Any]) -> str:
    """The orders no hub planned (``left``, :func:`left_out`), one a line
    (docs/outputs.md, "Hubs"): day, order id, row of the file, place, and why."""
    import csv
    import io

    import numpy as np

    mask, reason = left
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["day", "order_id", "row", "lng", "lat", "reason"])
    due = table.delivery_day
    for i in np.flatnonzero(mask):
        w.writerow(
            [
                str(due[i]),
                table.order_id[i],
                int(table.row[i]),
                f"{table.lng[i]:.6f}",
                f"{table.lat[i]:.6f}",
                reason[i],
            ]
        )
    return buf.getvalue()


def city_coverage(
    table: Any,
    days: list[dt.date],
    metrics: list[dict[str, Any]],
    hubs: list[Any],
    left: tuple[Any, Any],
) -> dict[str, Any]:
    """What share of the city's orders the hubs plan (docs/outputs.md, "Hubs"): per day
    and in all, orders due in the file, planned (in a hub's square and service hours)
    and delivered, the orders left out by reason, and each hub's part. Every share is
    of all orders due; the hubs' figures add up to the city's. ``left``: the orders
    left out and why (:func:`left_out`)."""
    import numpy as np

    mask, reason = left
    due_day = table.delivery_day
    per_day: list[dict[str, Any]] = []
    for day in days:
        on = due_day == np.datetime64(day.isoformat(), "D")
        due = int(on.sum())
        mine = [m for m in metrics if m["day"] == day.isoformat()]
        planned = sum(int(m["requests"]) for m in mine)
        delivered = sum(int(m["delivered"]) for m in mine)
        outside = int((on & mask & (reason == "outside every hub")).sum())
        per_day.append(
            {
                "day": day.isoformat(),
                "orders_due": due,
                "planned": planned,
                "delivered": delivered,
                "covered_share": planned / due if due else 0.0,
                "delivered_share": delivered / due if due else 0.0,
                "outside_hubs": outside,
                "outside_hours": int((on & mask).sum()) - outside,
                "hubs": len(mine),
            }
        )
    due_all = sum(d["orders_due"] for d in per_day)
    planned_all = sum(d["planned"] for d in per_day)
    delivered_all = sum(d["delivered"] for d in per_day)
    per_hub = []
    for h in hubs:
        mine = [m for m in metrics if m.get("hub") == h.id]
        per_hub.append(
            {
                "hub": h.id,
                "drones": h.drones,
                "orders_due": sum(int(m["orders_due"]) for m in mine),
                "planned": sum(int(m["requests"]) for m in mine),
                "delivered": sum(int(m["delivered"]) for m in mine),
                "outside_hours": sum(int(m["outside_hours"]) for m in mine),
            }
        )
    return {
        "drones": sum(int(h.drones or 0) for h in hubs),
        "orders_due": due_all,
        "planned": planned_all,
        "delivered": delivered_all,
        "covered_share": planned_all / due_all if due_all else 0.0,
        "delivered_share": delivered_all / due_all if due_all else 0.0,
        "outside_hubs": sum(d["outside_hubs"] for d in per_day),
        "outside_hours": sum(d["outside_hours"] for d in per_day),
        "left_out_orders": int(mask.sum()),
        "days": per_day,
        "hubs": per_hub,
    }


def city_line(city: dict[str, Any], n_hubs: int) -> str:
    """The run's closing line over a city: shares of all orders due, the rest by reason."""
    due = city["orders_due"]

    def pct(n: int) -> str:
        return f"{100 * n / due:.1f} %" if due else "-"

    line = (
        f"city: {city['planned']:,} of {due:,} orders due planned in {count(n_hubs, 'hub')} "
        f"({pct(city['planned'])}), {city['delivered']:,} delivered ({pct(city['delivered'])})"
        + (f" by {count(city['drones'], 'drone')}" if city.get("drones") else "")
    )
    left = [
        f"{city[k]:,} {label}"
        for k, label in (
            ("outside_hubs", "outside every hub"),
            ("outside_hours", "due outside service hours"),
        )
        if city.get(k)
    ]
    return line + (f"; left out: {', '.join(left)}" if left else "")
