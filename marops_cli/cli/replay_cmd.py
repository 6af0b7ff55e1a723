"""``marops replay-day``: replay whole days window by window and report the paper's metrics."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from ..errors import InputError
from ..io import output_set, run_meta
from . import options as o
from .common import console, guarded, is_terminal, make_config, print_drop_report, require_input
from .common import out as out_console

if TYPE_CHECKING:
    from ..sim.jobs import Scenario

METHOD_NAMES = "marops, ops-global, ops-random, greedy, squares, mappo, stay"

METRIC_COLUMNS = (
    ("mean_energy_kj", "energy kJ/drone", "{:.1f}"),
    ("avg_delay_h", "delay h", "{:.3f}"),
    ("delay_unfairness", "unfairness", "{:.3f}"),
    ("avg_early_h", "early h", "{:.3f}"),
    ("delivered", "delivered", "{}"),
    ("undelivered", "undelivered", "{}"),
    ("objective_j_mj", "J MJ", "{:.2f}"),
    ("objective_g_mj", "G MJ", "{:.2f}"),
    ("co2_g", "CO2 g", "{:.1f}"),
    ("runtime_s", "runtime s", "{:.3f}"),
)


@guarded
def replay_day(
    data: o.Data,
    out: Annotated[Path, typer.Option("--out", help="Output folder.")],
    date: Annotated[
        str | None, typer.Option("--date", help="One day to replay: 820, 0820 or 2022-08-20.")
    ] = None,
    dates: Annotated[
        str | None,
        typer.Option("--dates", help="Several days: 0820,0821 or 0820..0827 (one folder each)."),
    ] = None,
    depots: Annotated[
        Path | None, typer.Option("--depots", help="depots.json [segment the other days].")
    ] = None,
    depots_n: Annotated[
        int | None, typer.Option("--depots-n", help="Depots when segmenting here [16].")
    ] = None,
    segment: Annotated[
        str | None,
        typer.Option("--segment", help="kmeans or squares when segmenting here [the method's]."),
    ] = None,
    drones: o.Drones = None,
    method: Annotated[
        str,
        typer.Option("--method", help=f"One of {METHOD_NAMES} (docs/method.md §7) [marops]."),
    ] = "marops",
    policy: o.Policy = None,
    alpha: o.Alpha = None,
    ordering: o.Ordering = None,
    seed: o.Seed = None,
    fmt: Annotated[str, typer.Option("--format", help="parquet or json route files.")] = "parquet",
    plot: Annotated[
        bool, typer.Option("--plot", help="Draw each day's windows, areas and routes (PNG).")
    ] = False,
    force: Annotated[
        bool, typer.Option("--force", help="Replay days whose output already exists.")
    ] = False,
    year: o.Year = None,
    strict: o.Strict = False,
    config: o.Config = None,
) -> None:
    """Replay whole days window by window; write stops, routes and the paper's metrics."""
    from ..data.dates import parse_day, parse_days
    from ..sim.jobs import METHODS, load_fleet, load_scenario, method_policy

    require_input(data)
    if (date is None) == (dates is None):
        raise InputError("give exactly one of --date or --dates")
    if fmt not in ("parquet", "json"):
        raise InputError(f"--format expects parquet or json, got {fmt!r}")
    if method not in METHODS:
        raise InputError(f"unknown --method {method!r}: expected one of {', '.join(METHODS)}")
    cfg = make_config(
        config,
        data__year=year,
        data__strict=strict or None,
        segment__n_depots=depots_n,
        segment__method=segment or METHODS[method][0],
        plan__alpha=alpha,
        plan__ordering=ordering,
        sim__drones=drones,
        sim__seed=seed,
        sim__policy=policy,
    )
    days = [parse_day(date, cfg.data.year)] if date else parse_days(dates or "", cfg.data.year)
    scn = load_scenario(data, cfg, depots_path=depots, replay_days=days)
    print_drop_report(scn.table.report, data.name)
    pol = method_policy(method, cfg.sim.policy, cfg.sim.seed)
    fleet = load_fleet(None, scn.depots, cfg.sim.drones)
    policy_id = getattr(pol, "path", pol.name)
    all_metrics: list[dict[str, Any]] = []
    for day in days:
        folder = out if date else out / day.isoformat()
        done = folder / "metrics.json"
        if done.is_file() and not force:
            prior = json.loads(done.read_text(encoding="utf-8"))["days"]
            console.print(
                f"{day.isoformat()}: output exists in {folder}, skipped (--force replays)"
            )
            all_metrics.extend(prior)
            continue
        metrics = _replay_one(scn, day, fleet, pol, method, folder, fmt, plot, policy_id)
        all_metrics.append(metrics)
    if dates:
        meta = run_meta(command="replay-day", config=cfg, source=scn.table.source, method=method)
        with output_set() as files:
            files.write_json(out / "metrics.json", {"meta": meta, "days": all_metrics})
    _print_metrics(all_metrics)


def _replay_one(
    scn: Scenario,
    day: dt.date,
    fleet: Any,
    pol: Any,
    method: str,
    folder: Path,
    fmt: str,
    plot: bool,
    policy_id: Any,
) -> dict[str, Any]:
    from ..energy import EnergyModel
    from ..io.tables import build_tables, table_records, with_meta, write_parquet
    from ..sim.jobs import replay

    cfg = scn.cfg
    n_windows = cfg.data.n_windows
    if is_terminal():
        progress = Progress(
            TextColumn(f"{day.isoformat()} {method}"),
            BarColumn(),
            MofNCompleteColumn(),
            TimeElapsedColumn(),
            console=console,
            transient=True,
        )
        task = progress.add_task("windows", total=n_windows)
        with progress:
            res, reqs, metrics = replay(
                scn, day, fleet, pol, method, on_window=lambda p: progress.advance(task)
            )
    else:

        def log(p: Any) -> None:
            served = sum(len(r.stops) for r in p.routes)
            typer.echo(
                f"{day.isoformat()} {method} window {p.t + 1}/{n_windows}: "
                f"{served} delivered, {p.n_candidates} candidates, solver {p.selection.status}",
                err=True,
            )

        res, reqs, metrics = replay(scn, day, fleet, pol, method, on_window=log)
    model = EnergyModel(cfg.energy)
    stops, routes = build_tables(reqs, scn.depots, res.plans, model, method)
    meta = run_meta(
        command="replay-day",
        config=cfg,
        source=scn.table.source,
        policy=policy_id,
        method=method,
        seed=cfg.sim.seed,
        extra={"day": day.isoformat()},
        stamp=False,
    )
    with output_set() as files:
        if fmt == "parquet":
            files.write_with(
                folder / "stops.parquet", lambda p: write_parquet(with_meta(stops, meta), p)
            )
            files.write_with(
                folder / "routes.parquet", lambda p: write_parquet(with_meta(routes, meta), p)
            )
        else:
            files.write_json(folder / "stops.json", {"meta": meta, "stops": table_records(stops)})
            files.write_json(
                folder / "routes.json", {"meta": meta, "routes": table_records(routes)}
            )
        if plot:
            from ..sim.plot import plot_day

            files.write_with(folder / "routes.png", lambda p: plot_day(res, reqs, p))
        # metrics.json is renamed last: its presence means the day is complete.
        stamped = dict(meta, **run_meta(command="replay-day"))
        files.write_json(folder / "metrics.json", {"meta": stamped, "days": [metrics]})
    return metrics


def _print_metrics(rows: list[dict[str, Any]]) -> None:
    t = Table(title="day metrics (docs/method.md §8)", title_justify="left")
    t.add_column("day")
    t.add_column("method")
    for _, label, _ in METRIC_COLUMNS:
        t.add_column(label, justify="right")
    for m in rows:
        t.add_row(m["day"], m["method"], *[f.format(m[k]) for k, _, f in METRIC_COLUMNS])
    out_console.print(t)
