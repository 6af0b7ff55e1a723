"""``marops plan-window``: plan one window for the whole fleet."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from . import options as o
from .common import (
    STATE,
    begin,
    emit_json,
    guarded,
    info,
    protect_inputs,
    show_table,
    table,
)
from .common import out as out_console
from .progress import Terminal

if TYPE_CHECKING:
    from ..app.plan_window import PlannedWindow


@guarded
@o.takes_options("plan_window")
def plan_window_command(
    data: o.Data,
    depots: Annotated[Path, typer.Option("--depots", help="depots.json from marops segment.")],
    date: Annotated[str, typer.Option("--date", help="Day to plan: 820, 0820 or 2022-08-20.")],
    window: Annotated[int, typer.Option("--window", help="0-based window index in the day.")],
    out: Annotated[
        Path,
        typer.Option(
            "--out", help="Output folder: stops.parquet and routes.parquet (or .json files)."
        ),
    ],
    fleet: o.FleetFile = None,
    drones: o.Drones = None,
    delivered: Annotated[
        Path | None,
        typer.Option(
            "--delivered",
            help="Earlier stops.parquet (or its folder): the requests its stops delivered "
            "(order id and place) are not planned again.",
        ),
    ] = None,
    policy: o.Policy = None,
    trust_actor: o.TrustActor = False,
    method: o.Method = "marops",
    alpha: o.Alpha = None,
    ordering: o.Ordering = None,
    strict_cover: o.StrictCover = False,
    seed: o.Seed = None,
    year: o.Year = None,
    strict: o.Strict = False,
    force: o.Force = False,
    config: o.Config = None,
    fmt: o.Format = "parquet",
    geojson: o.Geojson = False,
    report: o.Report = False,
    tz: o.Tz = None,
    quiet: o.Quiet = False,
    as_json: o.Json = False,
    *,
    options: dict[str, Any],
) -> None:
    """Plan one time window: flight ranges, candidate plans, optimal plan selection."""
    data = begin(data, quiet=quiet, as_json=as_json, force=force)
    from ..app.options import planner_config
    from ..app.plan_window import plan_window as plan
    from ..data.dates import parse_day

    _check_outputs(out, fmt, geojson, report, [data, depots, fleet, delivered, config])
    cfg = planner_config(config, **options)
    day = parse_day(date, cfg.data.year, "--date")
    res = plan(
        data,
        cfg,
        day,
        window,
        depots=depots,
        method=method,
        fleet=fleet,
        delivered=delivered,
        out=out,
        fmt=fmt,
        geojson=geojson,
        report=report,
        progress=Terminal(),
    )
    _summary(res)
    info("wrote " + ", ".join(str(p) for p in res.files))
    if STATE["json"]:
        emit_json(_json_doc(res, day.isoformat(), window))


def _check_outputs(
    out: Path, fmt: str, geojson: bool, report: bool, inputs: list[Path | None]
) -> None:
    """Refuse, before any work, an output folder or format that cannot be written, and
    outputs that would replace one of the ``inputs``."""
    from ..app.inputs import check_format
    from ..app.plan_window import check_out
    from ..io.tables import route_file_paths

    check_out(out, fmt)
    check_format(fmt)
    protect_inputs(route_file_paths(out, fmt, geojson) + [out / "report.html"] * report, inputs)


def _json_doc(res: PlannedWindow, day: str, window: int) -> dict[str, Any]:
    """``--json``: the window's files, the rows dropped, the day's orders planned and
    left out, solver, objective and routes."""
    order_id, scope = res.requests.order_id, res.scope
    return {
        "command": "plan-window",
        "day": day,
        "window": window,
        "files": [str(p) for p in res.files],
        "rows": res.report.to_dict(),
        "orders": {
            "due": scope.orders_due,
            "planned": scope.planned,
            "outside_area": scope.outside_area,
            "outside_hours": scope.outside_hours,
        },
        "solver": res.solver,
        "objective": res.objective,
        "routes": [
            {
                "drone": r.drone,
                "start_depot": r.start,
                "end_depot": r.end,
                "action": r.action,
                "order_ids": [str(order_id[i]) for i in r.stops],
                "payload_kg": r.payload_kg,
                "distance_m": r.distance_m,
                "energy_j": r.energy_j,
            }
            for r in res.plan.routes
        ],
    }


def _summary(res: PlannedWindow) -> None:
    plan, models = res.plan, res.fleet.models()
    when = res.requests.window_start(plan.t).strftime("%Y-%m-%d %H:%M")
    t = table(
        f"window {plan.t} ({when}): {plan.n_candidates} candidate requests, "
        f"solver {plan.selection.status_text}"
        + (" (greedy fallback)" if plan.selection.fallback else "")
    )
    for col in ("drone", "from → to", "parcels", "km", "kJ", "battery %"):
        t.add_column(col, justify="right")
    for r in plan.routes:
        t.add_row(
            str(r.drone),
            f"{r.start} → {r.end}",
            str(len(r.stops)),
            f"{r.distance_m / 1000:.2f}",
            f"{r.energy_j / 1000:.1f}",
            f"{100 * r.energy_j / models[r.drone].cfg.battery_j:.1f}",
        )
    show_table(t)
    if plan.score is not None and not (STATE["json"] or STATE["quiet"]):  # docs/method.md §4.2
        sc = plan.score
        bound = ""
        if sc.bound_G is not None:  # [plan] bound = true (docs/method.md, "The bound")
            bound = f"; bound {sc.bound_G / 1e6:.3f} MJ, gap {100 * (sc.gap or 0.0):.2f} %"
        out_console.print(
            f"window objective: J {sc.J / 1e6:.3f} MJ, G {sc.G / 1e6:.3f} MJ "
            f"(served {sc.served} of {sc.pending} pending, energy {sc.energy_j / 1e3:.1f} kJ)"
            + bound
        )
