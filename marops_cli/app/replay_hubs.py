"""Replaying every hub of a city (docs/method.md §1.1) and the city's coverage."""

from __future__ import annotations

import datetime as dt
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from ..errors import InputError, in_hub
from ..io import folder_lock, output_set, run_meta
from ..io.meta import file_sha256
from .inputs import data_name, in_memory, read_data
from .messages import drop_report
from .progress import Progress
from .replay_areas import ReplayResult, Run, aggregate_days, make_area, replay_areas


def replay_hubs(
    data: Any,
    hubs_path: Path,
    out: Path | None,
    days: list[dt.date],
    several: bool,
    cfg: Any,
    fleet: Any,
    run: Run,
    progress: Progress,
) -> ReplayResult:
    """Replay every hub of a hubs file: each a study area with its own depots and fleet,
    into ``out/hub-<id>/``, and the city's coverage into ``out/metrics.json``."""
    from ..data.prepare import check_days_in_file
    from ..segment.hubs import hub_areas, load_hubs
    from ..sim.scenario import load_scenario

    hub_list = load_hubs(hubs_path, cfg.data)
    table = read_data(data, cfg.data)
    check_days_in_file(table, days)
    areas = []
    skipped: list[str] = []
    for a in hub_areas(table, cfg, hub_list, days):  # every hub-day checked before writing
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
                replay_days=days,
                table=a.table,
                hub=a.hub.id,
                cache=not in_memory(data),
            )
        except InputError as exc:  # a hub too sparse for its depots: which one
            raise in_hub(exc, a.hub.id) from None
        folder = out / f"hub-{a.hub.id}" if out is not None else None
        area = make_area(scn, folder, a.days, several, fleet, run, None, f"hub {a.hub.id}: ")
        area.report_top = out  # the city's pages share one plotly.js (docs/report.md)
        areas.append(area)
    # Said once every hub's fleet and folder passed: an error is a failed run's only line.
    drop_report(progress, table.report, data_name(data))
    for line in skipped:
        progress.message(line)
    with ExitStack() as held:
        if out is not None:  # the city's folder is the run's, with every hub's below it
            held.enter_context(folder_lock(out))
        per_area, tables = replay_areas(areas, run, progress)
        written = [f for a in areas for f in a.written]
        all_metrics = [m for rows in per_area for m in rows]
        city = city_coverage(table, days, all_metrics)
        total = aggregate_days(all_metrics)
        if out is not None:
            meta = run_meta(
                command="replay-day", config=cfg, source=table.source, method=run.method
            )
            meta["hubs_file"] = {"name": hubs_path.name, "sha256": file_sha256(hubs_path)}
            with output_set() as files:
                files.write_json(
                    out / "metrics.json",
                    {"meta": meta, "city": city, "days": all_metrics, "total": total},
                )
            written.append(out / "metrics.json")
            if run.report:  # the city's page; each hub's was written with its days
                from ..report import write_reports

                written += write_reports(out, below=False, shared=out)
    progress.message(
        f"city: {city['planned']:,} of {city['orders_due']:,} orders due planned in "
        f"{len(hub_list)} hubs ({100 * city['covered_share']:.1f} %), "
        f"{city['delivered']:,} delivered"
    )
    return ReplayResult(all_metrics, total, tables, city, out, written)


def city_coverage(table: Any, days: list[dt.date], metrics: list[dict[str, Any]]) -> dict[str, Any]:
    """What share of the city's orders the hubs plan (docs/outputs.md, "Hubs"): per day
    and in all, orders due in the file, planned (in a hub's square and service hours)
    and delivered."""
    import numpy as np

    due_day = table.delivery_day
    per_day: list[dict[str, Any]] = []
    for day in days:
        due = int((due_day == np.datetime64(day.isoformat(), "D")).sum())
        mine = [m for m in metrics if m["day"] == day.isoformat()]
        planned = sum(int(m["requests"]) for m in mine)
        delivered = sum(int(m["delivered"]) for m in mine)
        per_day.append(
            {
                "day": day.isoformat(),
                "orders_due": due,
                "planned": planned,
                "delivered": delivered,
                "covered_share": planned / due if due else 0.0,
                "hubs": len(mine),
            }
        )
    due_all = sum(d["orders_due"] for d in per_day)
    planned_all = sum(d["planned"] for d in per_day)
    return {
        "orders_due": due_all,
        "planned": planned_all,
        "delivered": sum(d["delivered"] for d in per_day),
        "covered_share": planned_all / due_all if due_all else 0.0,
        "days": per_day,
    }
