"""Replay whole days window by window (``replay-day``, docs/method.md §8): one study area
or every hub of a city, here or on workers or a Dask cluster; each day's stops, routes
and metrics, written into an output folder when one is given."""

from __future__ import annotations

import datetime as dt
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, get_args

from ..config import PlannerConfig, SegmentConfig, override
from ..errors import InputError, option
from .inputs import (
    Data,
    DepotsInput,
    check_format,
    data_name,
    given_depots,
    in_memory,
    protect_inputs,
    read_data,
)
from .messages import drop_report, late_orders
from .options import planner_config
from .progress import SILENT, Progress
from .replay_areas import SUMMED, DayTables, ReplayResult, Run, aggregate_days, make_area
from .replay_areas import replay_areas as _replay_areas

__all__ = [
    "SUMMED",
    "DayTables",
    "ReplayOptions",
    "ReplayResult",
    "aggregate_days",
    "check_options",
    "replay_config",
    "replay_days",
]


@dataclass(frozen=True)
class ReplayOptions:
    """How to replay: the method, the files, where the days run."""

    method: str = "marops"
    fmt: str = "parquet"
    """Route files: parquet or json."""
    plot: bool = False
    geojson: bool = False
    force: bool = False
    """Replay days whose output exists already."""
    workers: int = 1
    """Worker processes for several days or hubs."""
    scheduler: str | None = None
    """A Dask scheduler's address, or ``local``."""
    keep_tables: bool | None = None
    """Keep every replayed day's tables in the result [only when nothing is written]."""
    report: bool = False
    """Write report.html into each folder written (docs/report.md)."""


def check_options(options: ReplayOptions) -> None:
    """Refuse options no replay can run with, before any work."""
    from ..sim.scenario import METHODS
    from ..workers.pool import check_workers
    from .report import check_report

    check_report(options.report)
    check_workers(options.workers)
    if options.scheduler is not None:
        from ..workers.cluster import check_scheduler

        check_scheduler(options.scheduler)
    check_format(options.fmt)
    if options.method not in METHODS:
        raise InputError(
            f"unknown {option('method')} {options.method!r}: expected one of {', '.join(METHODS)}"
        )


def replay_config(
    config: str | Path | None, *, method: str = "marops", segment: str | None = None, **options: Any
) -> PlannerConfig:
    """The planner config of a replay's options (:func:`~marops_cli.app.options.planner_config`):
    depots segmented here use ``segment``, else the method's own segmentation."""
    from ..methods import method as method_spec

    kinds = get_args(SegmentConfig.model_fields["method"].annotation)
    if segment is not None and segment not in kinds:
        raise InputError(f"{option('segment')} expects {' or '.join(kinds)}, got {segment!r}")
    return planner_config(
        config, segmentation=segment or method_spec(method).segmentation, **options
    )


def plan_area(
    cfg: PlannerConfig, depots: Any = None, hubs: Any = None, fleet: Any = None
) -> tuple[PlannerConfig, bool]:
    """``(cfg, city)``: whether a run plans a city (a hubs file, or ``[data] area =
    "hubs"``, the default) or one study square, and its config saying so. Depots or a
    fleet file given (each drone placed at one area's depots), or a square's ``[data]
    center``, name one square whatever ``area`` says; a single square's config reads
    ``area = "square"`` (docs/method.md §1.1)."""
    if hubs is not None:
        return cfg, True
    one = depots is not None or fleet is not None or cfg.data.center is not None
    if cfg.data.area == "hubs" and not one:
        return cfg, True
    if cfg.data.area == "square":
        return cfg, False
    return override(cfg, data__area="square"), False


def replay_days(
    data: Data,
    cfg: PlannerConfig,
    days: list[dt.date],
    *,
    options: ReplayOptions = ReplayOptions(),
    out: str | Path | None = None,
    several: bool | None = None,
    depots: DepotsInput | None = None,
    fleet: Any = None,
    hubs: str | Path | None = None,
    protect: Mapping[str, Path | None] | None = None,
    progress: Progress = SILENT,
) -> ReplayResult:
    """Replay ``days`` of ``data`` with ``cfg``: depots from ``depots`` (a depots file or
    depots in memory; else segmented from the other days), the fleet of a fleet file or
    ``cfg.sim.drones`` drones, every hub of a ``hubs`` file instead of one study area.
    With ``out`` each day's files go into ``out`` (``out/<day>/`` when ``several``,
    default: more than one day) and a day already there with the same settings is kept;
    ``protect`` names more input files (flag -> path) the outputs must never replace."""
    check_options(options)
    from ..io.ownership import refuse_links_below
    from ..sim.scenario import loads_actor, method_policy, policy_files, replay_modules

    several = len(days) > 1 if several is None else several
    cfg, city = plan_area(cfg, depots, hubs, fleet)
    if options.scheduler is None and options.workers > 1 and (len(days) > 1 or city):
        from ..workers import warm_up

        # Several days or hubs may go to worker processes: their fork server imports
        # the planner (and torch for an actor) while this process reads the file.
        flies_torch = loads_actor(options.method, cfg.sim.policy, paper=cfg.ops.paper)
        warm_up(replay_modules(actor=flies_torch))
    folder = Path(out) if out is not None else None
    if folder is not None and folder.exists() and not folder.is_dir():
        raise InputError(f"{option('out')} must be a folder; this is a file", file=folder)
    if hubs is not None and depots is not None:
        raise InputError(f"{option('hubs')} segments each hub itself: drop {option('depots')}")
    if folder is not None:
        inputs = {"data": None if in_memory(data) else Path(data), "depots": depots}
        inputs.update({**(protect or {}), "fleet": fleet, "hubs": hubs})
        outputs = _outputs(folder, days, several, city, options)
        refuse_links_below(folder, outputs)
        actor = policy_files(options.method, cfg.sim.policy, ops=cfg.ops)
        protect_inputs(outputs, [*(_path(v) for v in inputs.values()), *actor])
        from ..io.atomic import check_free

        check_free(folder)  # no other run writes there, nor above it or inside it
    # A bad actor stops here.
    pol = method_policy(
        options.method, cfg.sim.policy, cfg.sim.seed, trust=cfg.sim.trust_actor, ops=cfg.ops
    )
    keep = folder is None if options.keep_tables is None else options.keep_tables
    run = Run(
        pol,
        options.method,
        options.fmt,
        options.plot,
        options.geojson,
        options.force,
        options.workers,
        options.scheduler,
        keep,
        options.report,
    )
    if city:
        from .replay_hubs import replay_hubs

        path = Path(hubs) if hubs is not None else None
        return replay_hubs(data, path, folder, days, several, cfg, fleet, run, progress)
    return _one_area(data, cfg, days, folder, several, depots, fleet, run, progress)


def _one_area(
    data: Data,
    cfg: PlannerConfig,
    days: list[dt.date],
    out: Path | None,
    several: bool,
    depots: DepotsInput | None,
    fleet: Any,
    run: Run,
    progress: Progress,
) -> ReplayResult:
    from ..data.prepare import prepare_day
    from ..sim.scenario import load_scenario

    table = read_data(data, cfg.data)
    given = given_depots(depots, cfg.segment.n_actions) if depots is not None else None
    scn = load_scenario(
        table.source.path,
        cfg,
        depots_path=given,
        replay_days=days,
        table=table,
        cache=not in_memory(data),
    )
    for day in days:  # every day has requests to plan, before anything is said or written
        prepare_day(scn.table, scn.frame, day, cfg.data)
    # The fleet file and the days already in ``out`` are checked before the drop report:
    # an error is the only line a failed run prints.
    area = make_area(scn, out, days, several, fleet, run, given)
    drop_report(progress, scn.table, data_name(data))
    inside = scn.frame.contains(*scn.frame.to_xy(scn.table.lng, scn.table.lat))
    late_orders(progress, scn.table, days, cfg, inside)
    rows, tables = _replay_areas([area], run, progress)
    return ReplayResult(rows[0], aggregate_days(rows[0]), tables, None, out, area.written)


def _path(value: Any) -> Path | None:
    return Path(value) if isinstance(value, str | Path) else None


def _hub_name(path: Path) -> bool:
    """Whether ``path`` is named as a hub's folder is (``hub-<id>``)."""
    return path.name.removeprefix("hub-").isdecimal()


def _outputs(
    out: Path, days: list[dt.date], several: bool, hubs: bool, options: ReplayOptions
) -> list[Path]:
    """Every file a replay into ``out`` may write (hub folders: those there already): a
    day's files in its folder, and over several days or hubs ``metrics.json`` (and
    ``report.html`` and the plotly.js the pages share) in the folder above them."""
    fmt = options.fmt
    names = [f"stops.{fmt}", f"routes.{fmt}", "metrics.json"]
    names += ["routes.png", "operations.png"] * options.plot + ["routes.geojson"] * options.geojson
    names += ["report.html"] * options.report
    above = ["metrics.json", *["report.html"] * options.report]

    def area(folder: Path) -> list[Path]:
        """One study area's files: its days' folders below ``folder`` when several."""
        if not several:
            return [folder / n for n in names]
        return [folder / n for n in above] + [
            folder / d.isoformat() / n for d in days for n in names
        ]

    shared = []
    if options.report and (several or hubs):
        from ..report.page import script_name

        shared = [out / script_name()]
    if not hubs:
        return area(out) + shared
    # out/hub-<id>/ below the city's metrics.json (a link named so is listed too, for
    # refuse_links_below to refuse, and a file named hub-<id>, which no folder can be)
    hub_folders = (
        [p for p in out.glob("hub-*") if p.is_dir() or p.is_symlink() or _hub_name(p)]
        if out.is_dir()
        else []
    )
    city = [out / n for n in above] + [out / "left_out.csv"]
    return city + shared + [p for a in hub_folders for p in area(a)]
