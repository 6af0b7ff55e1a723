"""``marops replay-day``: replay whole days window by window and report the paper's metrics."""

from __future__ import annotations

import datetime as dt
import json
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from ..errors import InputError
from ..io import folder_lock, output_set, run_meta
from ..io.atomic import allow_replacing_foreign
from ..io.meta import file_sha256
from . import options as o
from .common import (
    STATE,
    console,
    emit_json,
    guarded,
    info,
    is_terminal,
    make_config,
    print_day_scope,
    print_drop_report,
    refuse_overwriting_inputs,
    require_input,
    set_output,
    show_table,
    stopped,
    table,
    warn_undelivered,
)

if TYPE_CHECKING:
    from ..sim.jobs import Scenario


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
# Summed over days by ``aggregate_days``, in the order of ``total``.
SUMMED = (
    "requests",
    "delivered",
    "undelivered",
    "orders_due",
    "outside_area",
    "outside_hours",
    "energy_kj",
    "co2_g",
    "objective_j_mj",
    "objective_g_mj",
    "runtime_s",
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
    n_depots: Annotated[
        int | None, typer.Option("--n-depots", help="Depots when segmenting here [16].")
    ] = None,
    segment: Annotated[
        str | None,
        typer.Option("--segment", help="kmeans or squares when segmenting here [the method's]."),
    ] = None,
    drones: o.Drones = None,
    fleet: o.FleetFile = None,
    hubs: Annotated[
        Path | None,
        typer.Option(
            "--hubs",
            help="hubs.json from marops segment --hubs: replay every hub of the city, one "
            "folder each, and report the city's coverage [one study area].",
        ),
    ] = None,
    method: Annotated[
        str,
        typer.Option(
            "--method",
            help=f"One of {o.METHOD_NAMES} (docs/method.md §7) [marops].",
            show_default=False,
        ),
    ] = "marops",
    policy: o.Policy = None,
    alpha: o.Alpha = None,
    ordering: o.Ordering = None,
    seed: o.Seed = None,
    fmt: o.Format = "parquet",
    geojson: o.Geojson = False,
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
    workers: Annotated[
        int,
        typer.Option(
            "--workers",
            min=1,
            help="Worker processes for several days or hubs (with --scheduler local: the "
            "cluster's); one day of one area runs here.",
        ),
    ] = 2,
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler",
            help="Replay the days (and hubs) on a Dask cluster: its scheduler's address "
            "(tcp://HOST:8786), or local; needs pip install 'marops[cluster]' (README.md, "
            "Sweeps on a cluster).",
        ),
    ] = None,
    year: o.Year = None,
    strict: o.Strict = False,
    config: o.Config = None,
    quiet: o.Quiet = False,
    as_json: o.Json = False,
) -> None:
    """Replay whole days window by window; write stops, routes and the paper's metrics."""
    set_output(quiet, as_json)
    allow_replacing_foreign(force)
    from ..data.dates import parse_day, parse_days
    from ..data.prepare import prepare_day
    from ..sim.jobs import METHODS, load_scenario, loads_actor, method_policy, replay_modules

    require_input(data)
    if (date is None) == (dates is None):
        raise InputError("give exactly one of --date or --dates")
    if scheduler is not None:
        from ..workers.cluster import require_distributed

        require_distributed()
    if fmt not in ("parquet", "json"):
        raise InputError(f"--format expects parquet or json, got {fmt!r}")
    if method not in METHODS:
        raise InputError(f"unknown --method {method!r}: expected one of {', '.join(METHODS)}")
    cfg = make_config(
        config,
        data__year=year,
        data__strict=strict or None,
        data__tz=tz,
        segment__n_depots=n_depots,
        segment__method=segment or METHODS[method][0],
        plan__alpha=alpha,
        plan__ordering=ordering,
        sim__drones=drones,
        sim__seed=seed,
        sim__policy=policy,
    )
    days = [parse_day(date, cfg.data.year)] if date else parse_days(dates or "", cfg.data.year)
    if scheduler is None and workers > 1 and (len(days) > 1 or hubs is not None):
        from ..workers import warm_up

        # Several days or hubs may go to worker processes: their fork server imports
        # the planner (and torch for an actor) while this process reads the file.
        warm_up(replay_modules(actor=loads_actor(method, cfg.sim.policy)))
    if out.exists() and not out.is_dir():
        raise InputError("--out must be a folder; this is a file", file=out)
    if hubs is not None and depots is not None:
        raise InputError("--hubs segments each hub itself: drop --depots")
    names = (f"stops.{fmt}", f"routes.{fmt}", "metrics.json", "routes.png", "routes.geojson")
    folders = [out] if date else [out, *(out / d.isoformat() for d in days)]
    if hubs is not None:  # out/hub-<id>/ below the city's metrics.json
        areas = [p for p in out.glob("hub-*") if p.is_dir()] if out.is_dir() else []
        folders += [a / (d.isoformat() if dates else "") for a in areas for d in days]
    refuse_overwriting_inputs(
        [f / n for f in folders for n in names],
        data=data,
        depots=depots,
        config=config,
        fleet=fleet,
        hubs=hubs,
    )
    pol = method_policy(method, cfg.sim.policy, cfg.sim.seed)  # a bad actor file stops here
    run = _Run(pol, method, (fmt, plot, geojson), force, workers, scheduler)
    if hubs is not None:
        all_metrics = _replay_hubs(data, hubs, out, days, bool(dates), cfg, fleet, run)
    else:
        scn = load_scenario(data, cfg, depots_path=depots, replay_days=days)
        for day in days:  # every day has requests to plan, before anything is said or written
            prepare_day(scn.table, scn.frame, day, cfg.data)
        print_drop_report(scn.table.report, data.name)
        area = _area(scn, out, days, bool(dates), fleet, run, depots)
        all_metrics = _replay_areas([area], run)[0]
    _print_metrics(all_metrics, hubs is not None)
    if STATE["json"]:
        emit_json(
            {
                "command": "replay-day",
                "out": str(out),
                "metrics": str(out / "metrics.json"),
                "days": all_metrics,
            }
        )


@dataclass(frozen=True)
class _Run:
    """What every study area of the run shares: the policy, the files, the workers."""

    pol: Any
    method: str
    files_wanted: tuple[str, bool, bool]
    force: bool
    workers: int
    scheduler: str | None


@dataclass
class _Area:
    """A study area (the single one, or a hub) and the days to replay into its folder."""

    scn: Scenario
    fleet: Any
    out: Path
    days: list[dt.date]
    several: bool
    identity: dict[str, Any]
    keep: dict[dt.date, list[dict[str, Any]]]
    label: str = ""

    def folder(self, day: dt.date) -> Path:
        return self.out / day.isoformat() if self.several else self.out


def _area(
    scn: Scenario,
    out: Path,
    days: list[dt.date],
    several: bool,
    fleet: Path | None,
    run: _Run,
    depots: Path | None = None,
    label: str = "",
) -> _Area:
    """A study area to replay ``days`` of into ``out`` (a folder per day when
    ``several``); ``label`` names the hub in messages. A day folder that is complete is
    kept only if it was made with these settings: every day is checked here, before
    anything is replayed or written."""
    from ..sim.jobs import load_fleet

    cfg = scn.cfg
    drones_ = load_fleet(fleet, scn.depots, cfg.sim.drones, cfg)
    fmt = run.files_wanted[0]
    identity = _identity(
        scn, cfg, run.method, run.pol.identity, depots, fmt, drones_.describe(cfg.energy)
    )
    keep: dict[dt.date, list[dict[str, Any]]] = {}
    for day in days:
        done = (out / day.isoformat() if several else out) / "metrics.json"
        if done.is_file() and not run.force:
            keep[day] = _matching_days(done, identity)
    return _Area(scn, drones_, out, days, several, identity, keep, label)


def _replay_areas(areas: list[_Area], run: _Run) -> list[list[dict[str, Any]]]:
    """Replay every area's days (on workers when there are several, docs/decisions.md
    "Workers"), writing each day's files the moment it is done; returns each area's day
    metrics in day order."""
    from ..sim.days import DayJob

    done: dict[tuple[int, dt.date], dict[str, Any]] = {}
    jobs: list[DayJob] = []
    for i, a in enumerate(areas):
        for day in a.days:
            if day in a.keep:
                info(
                    f"{a.label}{day.isoformat()}: output with the same settings exists in "
                    f"{a.folder(day)}, skipped (--force replays)"
                )
            else:
                jobs.append(DayJob(len(jobs), i, day))
    with ExitStack() as locks:
        for a in areas:  # one run at a time in a folder; stale temporaries go
            locks.enter_context(folder_lock(a.out))
        try:
            if len(jobs) > 1 and (run.workers > 1 or run.scheduler is not None):
                _replay_on_workers(areas, jobs, run, _work(areas, run), done)
            elif jobs:
                work = _work(areas, run)
                work.use_policy(run.pol)  # the one the command loaded
                for job in jobs:
                    done[(job.area, job.day)] = _replay_here(areas[job.area], job, run, work)
        except KeyboardInterrupt as exc:  # Ctrl-C or SIGTERM: say what is kept
            if len(jobs) < 2:
                raise
            stopped(
                exc,
                f"{len(done)} of {len(jobs)} days are written: run the same command again "
                "to replay the others",
            )
        per_area = []
        for i, a in enumerate(areas):
            rows: list[dict[str, Any]] = []
            for day in a.days:
                rows.extend(a.keep[day] if day in a.keep else [done[(i, day)]])
            if a.several:
                cfg = a.scn.cfg
                meta = run_meta(
                    command="replay-day", config=cfg, source=a.scn.table.source, method=run.method
                )
                with output_set() as files:
                    files.write_json(
                        a.out / "metrics.json",
                        {"meta": meta, "days": rows, "total": aggregate_days(rows)},
                    )
            per_area.append(rows)
    return per_area


def _replay_hubs(
    data: Path,
    hubs_path: Path,
    out: Path,
    days: list[dt.date],
    several: bool,
    cfg: Any,
    fleet: Path | None,
    run: _Run,
) -> list[dict[str, Any]]:
    """Replay every hub of a hubs file (docs/method.md §1.1): each a study area with its
    own depots and fleet, into ``out/hub-<id>/``, and the city's coverage into
    ``out/metrics.json``. Returns every hub-day's metrics."""
    from ..data.prepare import check_days_in_file
    from ..data.reader import read_lade
    from ..segment.hubs import hub_areas, load_hubs
    from ..sim.jobs import load_scenario

    hub_list = load_hubs(hubs_path, cfg.data)
    table = read_lade(data, cfg.data)
    check_days_in_file(table, days)
    print_drop_report(table.report, data.name)
    areas = []
    for a in hub_areas(table, cfg, hub_list, days):  # every hub-day checked before writing
        for day in a.skipped:
            info(f"hub {a.hub.id}: no requests on {day.isoformat()} in its square, skipped")
        if not a.days:
            continue
        scn = load_scenario(data, a.cfg, replay_days=days, table=a.table, hub=a.hub.id)
        folder = out / f"hub-{a.hub.id}"
        areas.append(_area(scn, folder, a.days, several, fleet, run, None, f"hub {a.hub.id}: "))
    all_metrics = [m for rows in _replay_areas(areas, run) for m in rows]
    city = city_coverage(table, days, all_metrics)
    meta = run_meta(command="replay-day", config=cfg, source=table.source, method=run.method)
    meta["hubs_file"] = {"name": hubs_path.name, "sha256": file_sha256(hubs_path)}
    with output_set() as files:
        files.write_json(
            out / "metrics.json",
            {
                "meta": meta,
                "city": city,
                "days": all_metrics,
                "total": aggregate_days(all_metrics),
            },
        )
    info(
        f"city: {city['planned']:,} of {city['orders_due']:,} orders due planned in "
        f"{len(hub_list)} hubs ({100 * city['covered_share']:.1f} %), "
        f"{city['delivered']:,} delivered"
    )
    return all_metrics


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


def aggregate_days(days: list[dict[str, Any]]) -> dict[str, Any]:
    """Totals over several days: counts and energy summed, delays weighted by requests
    (docs/outputs.md, "Day metrics")."""
    from ..sim.metrics import metric_names

    req = sum(d["requests"] for d in days)
    delivered = sum(d["delivered"] for d in days)
    total: dict[str, Any] = {"days": len(days)}
    for k in metric_names(*SUMMED):
        total[k] = sum(d.get(k, 0) for d in days)
    total["delivered_share"] = delivered / req if req else 1.0
    total["avg_delay_h"] = sum(d["avg_delay_h"] * d["requests"] for d in days) / req if req else 0.0
    total["mean_energy_kj"] = sum(d["mean_energy_kj"] for d in days) / len(days) if days else 0.0
    return total


def _identity(
    scn: Scenario,
    cfg: Any,
    method: str,
    policy_id: Any,
    depots: Path | None,
    fmt: str,
    fleet: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """What makes a replayed day what it is: version, config, input, depots, fleet,
    policy, method, seed and format. Recorded in every day's metrics.json under ``settings``."""
    meta = run_meta(
        command="replay-day",
        config=cfg,
        source=scn.table.source,
        policy=policy_id,
        method=method,
        seed=cfg.sim.seed,
        stamp=False,
    )
    meta["frame"] = {
        "center_lng": scn.frame.center_lng,
        "center_lat": scn.frame.center_lat,
        "size_km": scn.frame.size_km,
    }
    if depots is not None:
        meta["depots_file"] = {"name": depots.name, "sha256": file_sha256(depots)}
    if fleet is not None:  # the resolved fleet: where each drone starts, its type
        meta["fleet"] = fleet
    meta["format"] = fmt
    meta.pop("command", None)
    return meta


def _flatten(doc: Any, prefix: str = "") -> dict[str, Any]:
    if not isinstance(doc, dict):
        return {prefix: doc}
    out: dict[str, Any] = {}
    for k, v in doc.items():
        out.update(_flatten(v, f"{prefix}.{k}" if prefix else str(k)))
    return out


def _matching_days(done: Path, identity: dict[str, Any]) -> list[dict[str, Any]]:
    """The day records of ``done`` if it was made with ``identity``; else a clear error."""
    try:
        doc = json.loads(done.read_text(encoding="utf-8"))
        prior = doc["meta"].get("settings")
        days = doc["days"]
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
        raise InputError(
            f"unreadable earlier output ({exc}); pass --force to replay or choose another --out",
            file=done,
        ) from exc
    if prior is None:
        raise InputError(
            "earlier output without recorded settings; pass --force to replay or choose "
            "another --out",
            file=done,
        )
    old, new = _flatten(prior), _flatten(identity)
    diff = [k for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)]
    if diff:
        shown = "; ".join(f"{k}: {old.get(k)!r} here, {new.get(k)!r} now" for k in diff[:3])
        more = f" (+{len(diff) - 3} more)" if len(diff) > 3 else ""
        raise InputError(
            f"holds a replay made with other settings ({shown}{more}); pass --force to "
            "replay it or choose another --out",
            file=done,
        )
    return list(days)


def _replay_here(area: _Area, job: Any, run: _Run, work: Any) -> dict[str, Any]:
    """Replay one day of ``work`` in this process, with a progress bar over its windows
    on a terminal (one log line per window otherwise); write its files; its metrics."""
    day = job.day
    n_windows = area.scn.cfg.data.n_windows
    progress = _progress(f"{day.isoformat()} {run.method}")
    if progress is not None:
        task = progress.add_task("windows", total=n_windows)
        with progress:
            out = work.run(job, on_window=lambda p: progress.advance(task))
    else:

        def log(p: Any) -> None:
            served = sum(len(r.stops) for r in p.routes)
            info(
                f"{area.label}{day.isoformat()} {run.method} window {p.t} of "
                f"0..{n_windows - 1}: {served} delivered, {p.n_candidates} candidates, "
                f"solver {p.selection.status_text}"
            )

        out = work.run(job, on_window=log)
    _write_day(area, day, out, run)
    return out.metrics


def _progress(label: str) -> Progress | None:
    """A progress bar on a terminal (None for logs, --quiet and --json)."""
    if not is_terminal() or STATE["quiet"] or STATE["json"]:
        return None
    return Progress(
        TextColumn(label),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=console,
        transient=True,
    )


def _work(areas: list[_Area], run: _Run) -> Any:
    """The run's days as work for any process (marops_cli/sim/days.py), built once."""
    from ..io.meta import file_sha256
    from ..methods import method as method_spec
    from ..sim.days import ReplayWork, only_days

    cfg = areas[0].scn.cfg
    actor = run.pol.identity
    return ReplayWork(
        {i: (only_days(a.scn, a.days), a.fleet) for i, a in enumerate(areas)},
        run.method,
        cfg.sim.policy,
        cfg.sim.seed,
        run.files_wanted[1],  # plot
        method_spec(run.method),
        file_sha256(actor) if isinstance(actor, Path) else None,
    )


def _replay_on_workers(
    areas: list[_Area],
    jobs: list[Any],
    run: _Run,
    work: Any,
    done: dict[tuple[int, dt.date], dict[str, Any]],
) -> None:
    """Replay ``jobs`` (days of areas) of ``work`` on worker processes or a Dask cluster;
    each day's files are written here as it comes back, its metrics go into ``done``."""
    from ..errors import RunError
    from ..workers import outcomes

    where = (
        f"{min(run.workers, len(jobs))} workers"
        if run.scheduler is None
        else "a local Dask cluster"
        if run.scheduler == "local"
        else f"the Dask scheduler at {run.scheduler}"
    )
    info(f"replay-day: {len(jobs)} days to replay on {where}")
    progress = _progress(f"replay-day {run.method}")
    with ExitStack() as stack:
        task = None
        if progress is not None:
            stack.enter_context(progress)
            task = progress.add_task("days", total=len(jobs))
        finished = stack.enter_context(
            outcomes(work, jobs, run.workers, run.scheduler, "replay-day")
        )
        for n, (index, out, error, code) in enumerate(finished, start=1):
            if error is not None:
                raise (InputError(error) if code == 2 else RunError(error))
            job = jobs[index]
            area = areas[job.area]
            _write_day(area, job.day, out, run)
            done[(job.area, job.day)] = out.metrics
            if progress is not None and task is not None:
                progress.update(task, completed=n)
            else:
                m = out.metrics
                info(
                    f"replay-day {n}/{len(jobs)}: {area.label}{job.day.isoformat()} "
                    f"{run.method}: {m['delivered']:,} of {m['requests']:,} delivered"
                )


def _write_day(area: _Area, day: dt.date, out: Any, run: _Run) -> None:
    """Say what the day planned and write its files; metrics.json last."""
    from ..io.tables import write_route_files

    fmt, _, geojson = run.files_wanted
    print_day_scope(out.scope, area.scn.cfg, area.label)
    warn_undelivered(out.metrics, len(area.fleet))
    folder = area.folder(day)
    # The route files' metadata: the run's identity (less the file format) and the day.
    meta = {k: v for k, v in area.identity.items() if k != "format"}
    meta.update(command="replay-day", day=day.isoformat())
    with output_set() as files:
        write_route_files(files, folder, out.stops, out.routes, meta, fmt, geojson)
        if out.png is not None:
            files.write_bytes(folder / "routes.png", out.png)
        # metrics.json is renamed last: its presence means the day is complete.
        stamped = dict(meta, **run_meta(command="replay-day"), settings=area.identity)
        files.write_json(folder / "metrics.json", {"meta": stamped, "days": [out.metrics]})


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
    show_table(t)
