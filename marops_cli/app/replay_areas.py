"""Replaying the days of study areas (one area, or every hub of a city), here or on
worker processes, each day's files written the moment it is done (docs/decisions.md,
"Workers"); its day records, tables and totals."""

from __future__ import annotations

import datetime as dt
import os
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import InputError, option
from ..io import folder_lock, output_set, run_meta
from ..io.ownership import JOURNAL
from .identity import identity, matching_days, route_meta, written_with
from .messages import day_scope, long_flights, undelivered
from .progress import Progress

if TYPE_CHECKING:
    import pyarrow as pa

    from ..segment.depots import Depots
    from ..sim.days import DayJob, DayOutput, ReplayWork
    from ..sim.scenario import Scenario

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

TOTALLED = (*SUMMED, "avg_delay_h", "mean_energy_kj", "delivered_share")
"""What ``aggregate_days`` reads of each day's record."""


@dataclass(frozen=True)
class DayTables:
    """A replayed day's stops and routes tables (with their ``marops`` metadata, as in
    the files) and, when drawn, its PNGs (``routes.png``, ``operations.png``)."""

    hub: int
    day: dt.date
    stops: pa.Table
    routes: pa.Table
    png: bytes | None = None
    ops_png: bytes | None = None


@dataclass(frozen=True)
class ReplayResult:
    """A replay: every (hub-)day's metrics record in order, their totals, the tables of
    the days replayed (when kept), for a city its coverage, and the files written."""

    days: list[dict[str, Any]]
    total: dict[str, Any]
    tables: list[DayTables] = field(default_factory=list)
    city: dict[str, Any] | None = None
    out: Path | None = None
    files: list[Path] = field(default_factory=list)
    """Every file this run wrote, in the order written (none for a day kept)."""


@dataclass(frozen=True)
class Run:
    """What every study area of a replay shares: the policy, the files, the workers."""

    pol: Any
    method: str
    fmt: str
    plot: bool
    geojson: bool
    force: bool
    workers: int
    scheduler: str | None
    keep_tables: bool
    report: bool = False
    """Write report.html into each folder (docs/report.md)."""


@dataclass
class Area:
    """A study area (the single one, or a hub) and the days to replay into its folder
    (``out`` None: nothing is written)."""

    scn: Scenario
    fleet: Any
    out: Path | None
    days: list[dt.date]
    several: bool
    identity: dict[str, Any]
    keep: dict[dt.date, list[dict[str, Any]]]
    label: str = ""
    written: list[Path] = field(default_factory=list)
    """The files written into the area's folders so far."""
    report_top: Path | None = None
    """The folder above ``out`` whose plotly.js the area's pages load (a city's, for a
    hub); None: the report's own (docs/report.md)."""
    placed: dict[dt.date, dict[Path, tuple[int, ...]]] = field(default_factory=dict)
    """Each day's files in its folder as this run kept or wrote them (:func:`_own_days`)."""
    summaries: list[Path] = field(default_factory=list)
    """The files over the area's days (``metrics.json`` over several days, a city's files,
    their pages): removed, when marops's, before the first of its days is replaced
    (:func:`_clear_summaries`)."""
    cleared: bool = False

    def folder(self, day: dt.date) -> Path | None:
        if self.out is None:
            return None
        return self.out / day.isoformat() if self.several else self.out


def make_area(
    scn: Scenario,
    out: Path | None,
    days: list[dt.date],
    several: bool,
    fleet: Any,
    run: Run,
    depots: Path | Depots | None = None,
    label: str = "",
) -> Area:
    """A study area to replay ``days`` of into ``out`` (a folder per day when
    ``several``); ``label`` names the hub in messages. A day folder that is complete is
    kept only if it was made with these settings: every day is checked here, before
    anything is replayed or written; one whose route files are not this run's output
    for the day (another day's copied in, a window's of ``plan-window``) is replayed."""
    from ..io.tables import route_file_paths
    from ..sim.fleet import Fleet
    from ..sim.scenario import load_fleet

    cfg = scn.cfg
    drones = (
        fleet if isinstance(fleet, Fleet) else load_fleet(fleet, scn.depots, cfg.sim.drones, cfg)
    )
    ident = identity(
        scn, run.method, run.pol.identity, depots, run.fmt, drones.describe(cfg.energy)
    )
    area = Area(scn, drones, out, days, several, ident, {}, label)
    if out is not None and several:
        area.summaries = [out / "metrics.json", out / "report.html"]
    # The files asked for too: a day kept without the map or figures asked for now is
    # replayed to write them, not kept without a word.
    routes = [p.name for p in route_file_paths(Path(), run.fmt, run.geojson)]
    asked = ["metrics.json", *routes] + ["routes.png", "operations.png"] * run.plot
    for day in days:
        folder = area.folder(day)
        # A day is done when all its files are there: one lost since is replayed.
        if folder is not None and all((folder / f).is_file() for f in asked) and not run.force:
            # The files as they are before their metrics are read: the summary claims
            # the day only if they are these still (a run that wrote the day meanwhile).
            placed = {folder / f: _signature(folder / f) for f in asked}
            records = matching_days(folder / "metrics.json", ident, day, TOTALLED)
            # Route files written since by another command or copied from another day
            # are marops's, not this day's: the day is replayed over them.
            meta = route_meta(ident, day)
            if all(written_with(folder / f, meta) for f in routes):
                area.placed[day] = placed
                area.keep[day] = records
    return area


DAY_OUTPUTS = (
    "stops.parquet",
    "routes.parquet",
    "stops.json",
    "routes.json",
    "routes.geojson",
    "routes.png",
    "operations.png",
    "report.html",
)
"""What a replayed day's folder may hold beside its metrics.json (docs/outputs.md)."""


def _clear_day(folder: Path, writes: list[Path]) -> None:
    """Before a day's files go into ``folder``: remove an earlier run's outputs of the
    day that this run does not write again (a map or figures not asked for now, route
    files of the other format, the day's page, written again at the end with
    ``--report``), so none is taken for this run's. Only files marops wrote go
    (:func:`~marops_cli.io.ownership.remove_ours`)."""
    from ..io.ownership import remove_ours

    remove_ours(folder / name for name in DAY_OUTPUTS if folder / name not in writes)


def _clear_summaries(area: Area) -> None:
    """Before the first of ``area``'s days is replaced: remove the summaries over its
    days that marops wrote (``area.summaries``), so that none, left by an earlier run,
    claims a day that holds this run's files should this run stop before writing its
    own."""
    if not area.cleared:
        from ..io.ownership import remove_ours

        remove_ours(area.summaries)
        area.cleared = True


def _signature(path: Path) -> tuple[int, ...]:
    """Which file is at ``path``: device, inode, size and time of its last change; a
    file renamed into its place, or written over, has another. Empty when none is."""
    try:
        st = os.lstat(path)
    except OSError:
        return ()
    return _stat_signature(st)


def _stat_signature(st: os.stat_result) -> tuple[int, ...]:
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)


def _own_days(area: Area) -> None:
    """Before a summary claims an area's days (its ``metrics.json`` over several days, a
    city's): each day's folder still holds the files this run kept or wrote there, not
    another run's written meanwhile; else one line naming the folder (exit 2) and no
    summary is written."""
    for day in area.days:
        for path, sig in area.placed.get(day, {}).items():
            if _signature(path) != sig:
                did = "kept" if day in area.keep else "wrote"
                raise InputError(
                    f"was written by another run while this one ran ({path.name} is not the "
                    f"file this run {did}); no summary claims it: run the command again "
                    f"when no other run writes into {option('out')}",
                    file=path.parent,
                )


_Done = dict[tuple[int, dt.date], tuple[dict[str, Any], "DayTables | None"]]


def replay_areas(
    areas: list[Area], run: Run, progress: Progress
) -> tuple[list[list[dict[str, Any]]], list[DayTables]]:
    """Replay every area's days (on workers when there are several), writing each day's
    files the moment it is done; each area's day metrics in day order, and the kept
    tables. An interrupt of several days carries a note: what the run keeps."""
    from ..sim.days import DayJob

    done: _Done = {}
    jobs: list[DayJob] = []
    kept: list[tuple[str, Path | None]] = []
    for i, a in enumerate(areas):
        for day in a.days:
            if day in a.keep:
                kept.append((f"{a.label}{day.isoformat()}", a.folder(day)))
            else:
                jobs.append(DayJob(len(jobs), i, day))
    _say_kept(kept, areas, progress)
    if areas:
        long_flights(progress, [t for a in areas for t in a.fleet.types], areas[0].scn.cfg)
    with ExitStack() as locks:
        for a in areas:  # one run at a time in a folder; stale temporaries go
            if a.out is not None:
                locks.enter_context(folder_lock(a.out))
        try:
            if len(jobs) > 1 and (run.workers > 1 or run.scheduler is not None):
                _replay_on_workers(areas, jobs, run, _work(areas, run), done, progress)
            elif jobs:
                work = _work(areas, run)
                work.use_policy(run.pol)  # the one the caller loaded
                for job in jobs:
                    done[(job.area, job.day)] = _replay_here(
                        areas[job.area], job, run, work, progress
                    )
        except KeyboardInterrupt as exc:  # Ctrl-C or SIGTERM: the caller says what is kept
            if len(jobs) > 1:
                what = "hub-days" if len(areas) > 1 else "days"
                exc.add_note(
                    f"{len(done)} of {len(jobs)} {what} are written: run the same command "
                    "again to replay the others"
                )
            raise
        replayed = [(job, areas[job.area]) for job in jobs]
        undelivered(
            progress, [(done[j.area, j.day][0], len(a.fleet), a.label) for j, a in replayed]
        )
        return _collect(areas, run, done, progress)


def _say_kept(kept: list[tuple[str, Path | None]], areas: list[Area], progress: Progress) -> None:
    """Name the days kept as they were (their output exists with the same settings): each
    of a few, one line for many (a month re-run to add a day)."""
    if len(kept) <= 3:
        for name, folder in kept:
            progress.message(
                f"{name}: output with the same settings exists in {folder}, "
                "skipped (--force replays)"
            )
    elif kept:
        unit = "hub-days" if any(a.label for a in areas) else "days"
        progress.message(
            f"{len(kept)} {unit} have output with the same settings ({kept[0][0]} … "
            f"{kept[-1][0]}), skipped (--force replays)"
        )


def _collect(
    areas: list[Area], run: Run, done: _Done, progress: Progress
) -> tuple[list[list[dict[str, Any]]], list[DayTables]]:
    """Each area's day records (kept or replayed) in day order, with the metrics.json of
    an area replayed a folder per day; the tables kept."""
    per_area, tables = [], []
    for i, a in enumerate(areas):
        rows: list[dict[str, Any]] = []
        for day in a.days:
            if day in a.keep:
                rows.extend(a.keep[day])
                continue
            metrics, kept = done[(i, day)]
            rows.append(metrics)
            if kept is not None:
                tables.append(kept)
        if a.out is not None and (a.several or a.label):  # a summary claims the days
            _own_days(a)
        if a.several and a.out is not None:
            meta = run_meta(
                command="replay-day", config=a.scn.cfg, source=a.scn.table.source, method=run.method
            )
            with output_set() as files:
                files.write_json(
                    a.out / "metrics.json",
                    {"meta": meta, "days": rows, "total": aggregate_days(rows)},
                )
            a.written.append(a.out / "metrics.json")
        if run.report and a.out is not None:
            from .report import write_pages

            a.written += write_pages(a.out, a.scn.depots, progress, shared=a.report_top)
        per_area.append(rows)
    return per_area, tables


def _replay_here(
    area: Area, job: DayJob, run: Run, work: ReplayWork, progress: Progress
) -> tuple[dict[str, Any], DayTables | None]:
    """Replay one day of ``work`` in this process, a progress step per window: a bar's
    step, with no line of its own (a log gets the day's line, :func:`_finish_day`, not
    one per window)."""
    day = job.day
    n_windows = area.scn.cfg.data.n_windows

    def step(_: Any) -> None:
        progress.advance()

    progress.start(f"{area.label}{day.isoformat()} {run.method}", n_windows, "windows")
    try:
        out = work.run(job, on_window=step)
    finally:
        progress.finish()
    return _finish_day(area, day, out, run, progress)


def _work(areas: list[Area], run: Run) -> ReplayWork:
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
        run.plot,
        method_spec(run.method),
        file_sha256(actor) if isinstance(actor, Path) else None,
    )


def _replay_on_workers(
    areas: list[Area],
    jobs: list[DayJob],
    run: Run,
    work: ReplayWork,
    done: _Done,
    progress: Progress,
) -> None:
    """Replay ``jobs`` (days of areas) of ``work`` on worker processes or a Dask cluster;
    each day's files are written here as it comes back, its metrics go into ``done``."""
    from ..workers import outcomes
    from ..workers.pool import local_workers, workers_note

    if (note := workers_note(run.workers, run.scheduler, len(jobs))) is not None:
        progress.warning(note)
    where = (
        f"{local_workers(min(run.workers, len(jobs)))} workers"
        if run.scheduler is None
        else "a local Dask cluster"
        if run.scheduler == "local"
        else f"the Dask scheduler at {run.scheduler}"
    )
    unit = "hub-days" if any(a.label for a in areas) else "days"
    progress.message(f"replay-day: {len(jobs)} {unit} to replay on {where}")
    progress.start(f"replay-day {run.method}", len(jobs), unit)
    try:
        with outcomes(work, jobs, run.workers, run.scheduler, "replay-day") as finished:
            for n, outcome in enumerate(finished, start=1):
                out = outcome.value()
                job = jobs[outcome.index]
                area = areas[job.area]
                done[(job.area, job.day)] = _finish_day(area, job.day, out, run, progress)
                m = out.metrics
                progress.advance(
                    f"replay-day {n}/{len(jobs)}: {area.label}{job.day.isoformat()} "
                    f"{run.method}: {m['delivered']:,} of {m['requests']:,} delivered"
                )
    finally:
        progress.finish()


def _finish_day(
    area: Area, day: dt.date, out: DayOutput, run: Run, progress: Progress
) -> tuple[dict[str, Any], DayTables | None]:
    """Say what the day planned and write its files (metrics.json last) when the area
    has a folder; its metrics and, when kept, its tables."""
    from ..io.tables import route_file_paths, with_meta, write_route_files

    day_scope(progress, out.scope, area.scn.cfg, area.label)
    meta = route_meta(area.identity, day)
    folder = area.folder(day)
    if folder is not None:
        writes = route_file_paths(folder, run.fmt, run.geojson)
        writes += [folder / "routes.png"] * (out.png is not None)
        writes += [folder / "operations.png"] * (out.ops_png is not None)
        _clear_summaries(area)
        _clear_day(folder, writes)
        with output_set() as files:
            paths = write_route_files(
                files, folder, out.stops, out.routes, meta, run.fmt, run.geojson
            )
            if out.png is not None:
                files.write_bytes(folder / "routes.png", out.png)
                paths.append(folder / "routes.png")
            if out.ops_png is not None:
                files.write_bytes(folder / "operations.png", out.ops_png)
                paths.append(folder / "operations.png")
            # metrics.json is renamed last: its presence means the day is complete.
            stamped = dict(meta, **run_meta(command="replay-day"), settings=area.identity)
            files.write_json(folder / "metrics.json", {"meta": stamped, "days": [out.metrics]})
        area.written += [*paths, folder / "metrics.json"]
        area.placed[day] = {
            p: _stat_signature(st) for p, st in files.placed.items() if p.name != JOURNAL
        }
    if not run.keep_tables:
        return out.metrics, None
    tables = DayTables(
        area.scn.hub,
        day,
        with_meta(out.stops, meta),
        with_meta(out.routes, meta),
        out.png,
        out.ops_png,
    )
    return out.metrics, tables


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
