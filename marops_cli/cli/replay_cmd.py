"""``marops replay-day``: replay whole days window by window and report the paper's metrics."""

from __future__ import annotations

import datetime as dt
from pathlib import Path
from typing import Annotated, Any

import typer

from ..errors import InputError
from ..io.paths import natural_key
from . import options as o
from .common import (
    STATE,
    begin,
    emit_json,
    guarded,
    info,
    show_table,
    table,
)
from .progress import Terminal

# Columns of the day table; headers and formats from the spec (sim/metrics.py, imported
# when used: the simulator is not loaded to start the CLI).
METRIC_COLUMNS = (
    "mean_energy_kj",
    "avg_delay_h",
    "delay_unfairness",
    "avg_early_h",
    "delivered",
    "undelivered",
    "objective_j_mj",
    "objective_g_mj",
    "co2_g",
    "runtime_s",
)


@guarded
@o.takes_options("replay_day")
def replay_day_command(
    data: o.Data,
    out: o.OutFolder,
    date: Annotated[
        str | None, typer.Option("--date", help="One day to replay: 820, 0820 or 2022-08-20.")
    ] = None,
    dates: Annotated[
        str | None,
        typer.Option("--dates", help="Several days: 0820,0821 or 0820..0827 (one folder each)."),
    ] = None,
    depots: Annotated[
        Path | None, typer.Option("--depots", help="depots.json [default: segment the other days].")
    ] = None,
    n_depots: o.NDepots = None,
    segment: o.Segment = None,
    drones: o.Drones = None,
    fleet: o.FleetFile = None,
    hubs: Annotated[
        Path | None,
        typer.Option(
            "--hubs",
            help="hubs.json from marops segment --hubs: replay every hub of the city, one "
            "folder each, and report the city's coverage [default: as --area says].",
        ),
    ] = None,
    area: o.Area = None,
    city_drones: o.CityDrones = None,
    method: o.Method = "marops",
    policy: o.Policy = None,
    trust_actor: o.TrustActor = False,
    alpha: o.Alpha = None,
    ordering: o.Ordering = None,
    seed: o.Seed = None,
    fmt: o.Format = "parquet",
    geojson: o.Geojson = False,
    report: o.Report = False,
    tz: o.Tz = None,
    plot: Annotated[
        bool, typer.Option("--plot", help="Draw each day's windows, areas and routes (PNG).")
    ] = False,
    force: Annotated[
        bool,
        typer.Option(
            "--force",
            help="Replay days whose output already exists; replace files marops did not write.",
        ),
    ] = False,
    workers: o.Workers = 2,
    scheduler: o.Scheduler = None,
    year: o.Year = None,
    strict: o.Strict = False,
    config: o.Config = None,
    quiet: o.Quiet = False,
    as_json: o.Json = False,
    *,
    options: dict[str, Any],
) -> None:
    """Replay whole days window by window; write stops, routes and the paper's metrics."""
    data = begin(data, quiet=quiet, as_json=as_json, force=force)
    from ..app.replay import ReplayOptions, check_options, replay_config, replay_days

    if (date is None) == (dates is None):
        raise InputError("give exactly one of --date or --dates")
    opts = ReplayOptions(method, fmt, plot, geojson, force, workers, scheduler, report=report)
    check_options(opts)
    cfg = replay_config(config, method=method, **options)
    res = replay_days(
        data,
        cfg,
        _days(date, dates, cfg.data.year),
        options=opts,
        out=out,
        several=bool(dates),
        depots=depots,
        fleet=fleet,
        hubs=hubs,
        protect={"config": config},
        progress=Terminal(),
    )
    _print_metrics(res.days, res.city is not None)
    info(_wrote(out, res.files))
    if STATE["json"]:
        emit_json(_json_doc(res, out, report))


def _json_doc(res: Any, out: Path, report: bool) -> dict[str, Any]:
    """``--json``: the files written, the metrics file, each day's metrics, the city's."""
    doc: dict[str, Any] = {"out": str(out), "files": [str(f) for f in res.files]}
    doc.update({"metrics": str(out / "metrics.json"), "days": res.days})
    doc.update({"city": res.city} if res.city is not None else {})
    doc.update({"report": str(out / "report.html")} if report else {})
    return {"command": "replay-day", **doc}


def _days(date: str | None, dates: str | None, year: int) -> list[dt.date]:
    """The day of ``--date``, or the days of ``--dates``."""
    from ..data.dates import parse_day, parse_days

    if date is not None:
        return [parse_day(date, year, "--date")]
    return parse_days(dates or "", year, "--dates")


def _wrote(out: Path, files: list[Path]) -> str:
    """The closing line: the files written; for many, their count and folders."""
    if not files:
        return f"nothing written: {out} holds these days with these settings (--force replays)"
    if len(files) <= 8:
        return "wrote " + ", ".join(map(str, files))
    # The folders right below ``out`` (days, or hubs holding days), hub-10 after hub-9.
    below_out = {out / f.relative_to(out).parts[0] for f in files if f.parent != out}
    folders = sorted(below_out, key=natural_key)
    shown = folders if len(folders) <= 2 else [folders[0], "…", folders[-1]]
    below = ", ".join(map(str, shown))
    return f"wrote {len(files)} files: {out}/metrics.json and those in {below}"


def _print_metrics(rows: list[dict[str, Any]], hubs: bool = False) -> None:
    from ..sim.metrics import metric_specs

    specs = metric_specs(*METRIC_COLUMNS)
    t = table("day metrics (docs/method.md §8)")
    if hubs:
        t.add_column("hub", justify="right")
    t.add_column("day", no_wrap=True, min_width=10)
    t.add_column("method", no_wrap=True)
    for s in specs:
        t.add_column(s.header, justify="right")
    for m in rows:
        cells = [m["day"], m["method"], *[s.day_fmt.format(m[s.name]) for s in specs]]
        t.add_row(*([str(m.get("hub", 0))] if hubs else []), *cells)
    show_table(t, keys=3 if hubs else 2)
