"""``marops plan-window``: plan one window for the whole fleet."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from ..errors import InputError
from ..io.atomic import allow_replacing_foreign
from . import options as o
from .common import (
    STATE,
    emit_json,
    guarded,
    info,
    make_config,
    print_day_scope,
    print_drop_report,
    refuse_overwriting_inputs,
    require_input,
    set_output,
    show_table,
    table,
)
from .common import out as out_console

if TYPE_CHECKING:
    from collections.abc import Sequence

    from ..energy import EnergyModel


@guarded
def plan_window(
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
            help="Earlier stops.parquet (or its folder): its orders are not planned again.",
        ),
    ] = None,
    policy: o.Policy = None,
    method: Annotated[
        str,
        typer.Option(
            "--method",
            help=f"One of {o.METHOD_NAMES} (docs/method.md §7) [marops].",
            show_default=False,
        ),
    ] = "marops",
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
    tz: o.Tz = None,
    quiet: o.Quiet = False,
    as_json: o.Json = False,
) -> None:
    """Plan one time window: flight ranges, candidate plans, optimal plan selection."""
    set_output(quiet, as_json)
    allow_replacing_foreign(force)
    from ..data.dates import parse_day
    from ..io import folder_lock, output_set, run_meta
    from ..io.meta import file_sha256
    from ..io.tables import write_route_files
    from ..sim.days import DayScope
    from ..sim.jobs import (
        delivered_orders,
        load_fleet,
        load_scenario,
        method_policy,
        plan_one_window,
        route_tables,
    )

    require_input(data)
    if out.suffix in (".parquet", ".json"):
        raise InputError(
            f"--out is a folder (it gets stops.{fmt} and routes.{fmt}), not a file: {out.name}"
        )
    if out.exists() and not out.is_dir():
        raise InputError("--out must be a folder; this is a file", file=out)
    if fmt not in ("parquet", "json"):
        raise InputError(f"--format expects parquet or json, got {fmt!r}")
    refuse_overwriting_inputs(
        [out / f"stops.{fmt}", out / f"routes.{fmt}", out / "routes.geojson"],
        data=data,
        depots=depots,
        fleet=fleet,
        delivered=delivered,
        config=config,
    )
    cfg = make_config(
        config,
        data__year=year,
        data__strict=strict or None,
        data__tz=tz,
        plan__alpha=alpha,
        plan__ordering=ordering,
        plan__strict_cover=strict_cover or None,
        sim__drones=drones,
        sim__seed=seed,
        sim__policy=policy,
    )
    day = parse_day(date, cfg.data.year)
    pol = method_policy(method, cfg.sim.policy, cfg.sim.seed)
    # Every input is checked before anything is said about the data (the drop report
    # comes after the plan): an error is the only line a failed run prints.
    done = delivered_orders(delivered) if delivered is not None else None
    scn = load_scenario(data, cfg, depots_path=depots, replay_days=[day])
    drones_ = load_fleet(fleet, scn.depots, cfg.sim.drones, cfg)
    plan, reqs = plan_one_window(scn, day, window, drones_, pol, done)
    print_drop_report(scn.table.report, data.name)
    print_day_scope(DayScope.of(reqs), cfg)
    stops, routes = route_tables(scn, reqs, [plan], drones_, method)
    meta = run_meta(
        command="plan-window",
        config=cfg,
        source=scn.table.source,
        policy=pol.identity,
        method=method,
        seed=cfg.sim.seed,
        extra={
            "day": day.isoformat(),
            "window": window,
            "solver": {
                "status": plan.selection.status_text,
                "fallback": plan.selection.fallback,
                "objective": plan.selection.objective,
            },
            "objective": plan.score.as_dict() if plan.score else None,
            "frame": {
                "center_lng": scn.frame.center_lng,
                "center_lat": scn.frame.center_lat,
                "size_km": scn.frame.size_km,
            },
            "depots_file": {"name": depots.name, "sha256": file_sha256(depots)},
            "fleet": drones_.describe(cfg.energy),
        },
        stamp=False,
    )
    with folder_lock(out), output_set() as files:
        written = write_route_files(files, out, stops, routes, meta, fmt, geojson)
    _summary(plan, drones_.models(), reqs.window_start(window).strftime("%Y-%m-%d %H:%M"))
    info("wrote " + ", ".join(str(p) for p in written))
    if STATE["json"]:
        emit_json(
            {
                "command": "plan-window",
                "day": day.isoformat(),
                "window": window,
                "files": [str(p) for p in written],
                "solver": meta["solver"],
                "objective": meta["objective"],
                "routes": [
                    {
                        "drone": r.drone,
                        "start_depot": r.start,
                        "end_depot": r.end,
                        "action": r.action,
                        "order_ids": [str(reqs.order_id[i]) for i in r.stops],
                        "payload_kg": r.payload_kg,
                        "distance_m": r.distance_m,
                        "energy_j": r.energy_j,
                    }
                    for r in plan.routes
                ],
            }
        )


def _summary(plan, models: Sequence[EnergyModel], when: str) -> None:  # type: ignore[no-untyped-def]
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
    if plan.score is not None and not (STATE["json"] or STATE["silent"]):  # docs/method.md §4.2
        sc = plan.score
        out_console.print(
            f"window objective: J {sc.J / 1e6:.3f} MJ, G {sc.G / 1e6:.3f} MJ "
            f"(served {sc.served} of {sc.pending} pending, energy {sc.energy_j / 1e3:.1f} kJ)"
        )
