"""Plan one time window for the whole fleet (``plan-window``, docs/method.md §4): flight
ranges, candidate plans, the optimal selection; its stops and routes tables."""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..config import PlannerConfig
from ..errors import InputError, option
from .inputs import (
    Data,
    DepotsInput,
    check_format,
    data_name,
    depots_record,
    given_depots,
    in_memory,
    read_data,
)
from .messages import day_scope, drop_report, long_flights, unservable_requests
from .progress import SILENT, Progress

if TYPE_CHECKING:
    import pyarrow as pa

    from ..data.table import DayRequests, DropReport
    from ..plans.window import WindowPlan
    from ..segment.depots import Depots
    from ..sim.days import DayScope
    from ..sim.fleet import Fleet


@dataclass(frozen=True)
class PlannedWindow:
    """A planned window: the plan, the day's requests it was planned from, the fleet,
    its stops and routes tables (with their ``marops`` metadata, as in the files), the
    files written, the rows the data dropped (``report``) and the day's orders planned
    and left out (``scope``)."""

    plan: WindowPlan
    requests: DayRequests
    fleet: Fleet
    stops: pa.Table
    routes: pa.Table
    meta: dict[str, Any]
    files: list[Path]
    report: DropReport
    scope: DayScope

    @property
    def solver(self) -> dict[str, Any]:
        """The selection's status, fallback and objective."""
        return dict(self.meta["solver"])

    @property
    def objective(self) -> dict[str, Any] | None:
        """The window objective (docs/method.md §4.2), or None."""
        return self.meta["objective"]


def check_out(out: str | Path, fmt: str) -> None:
    """``--out`` is the folder of the route files, not a file nor a file's name."""
    out = Path(out)
    if out.suffix in (".parquet", ".json"):
        raise InputError(
            f"{option('out')} is a folder (it gets stops.{fmt} and routes.{fmt}), not a file: "
            f"{out.name}"
        )
    if out.exists() and not out.is_dir():
        raise InputError(f"{option('out')} must be a folder; this is a file", file=out)


def check_window(window: int, cfg: PlannerConfig) -> None:
    """``window`` is one of the day's windows (0 to the service hours' last)."""
    last = cfg.data.n_windows - 1
    if not 0 <= window <= last:
        raise InputError(f"{option('window')} {window} is outside 0..{last}")


def plan_window(
    data: Data,
    cfg: PlannerConfig,
    day: dt.date,
    window: int,
    *,
    depots: DepotsInput,
    method: str = "marops",
    fleet: Any = None,
    delivered: str | Path | None = None,
    out: str | Path | None = None,
    fmt: str = "parquet",
    geojson: bool = False,
    report: bool = False,
    progress: Progress = SILENT,
) -> PlannedWindow:
    """Plan window ``window`` of ``day`` with the depots of ``depots`` (a depots file or
    depots in memory) and the fleet of a fleet file (else ``cfg.sim.drones`` drones),
    leaving out the orders an earlier stops file (``delivered``) delivered; with ``out``
    write its route files there (and with ``report`` its report.html, docs/report.md)."""
    from ..io import folder_lock, output_set
    from ..io.ownership import check_outputs, register_inputs
    from ..io.tables import route_file_paths, with_meta, write_route_files
    from ..sim.days import DayScope
    from ..sim.fleet import Fleet
    from ..sim.scenario import (
        delivered_file,
        delivered_orders,
        load_fleet,
        load_scenario,
        method_policy,
        plan_one_window,
        policy_files,
        route_tables,
    )
    from .report import check_report

    stops = None if delivered is None else delivered_file(delivered)
    register_inputs([data, depots, fleet, stops])  # never an output
    check_format(fmt)
    check_report(report and out is not None)
    register_inputs(policy_files(method, cfg.sim.policy, ops=cfg.ops))  # the actor's too
    if out is not None:  # before any work: an input or a file marops did not write
        from ..io.atomic import check_free

        check_out(out, fmt)
        check_outputs(route_file_paths(Path(out), fmt, geojson))
        check_free(out)  # no other run writes there, nor above it or inside it
    pol = method_policy(
        method, cfg.sim.policy, cfg.sim.seed, trust=cfg.sim.trust_actor, ops=cfg.ops
    )
    # Every input is checked before anything is said about the data (the drop report
    # comes after the plan): an error is the only line a failed run prints.
    done = delivered_orders(stops) if stops is not None else None
    table = read_data(data, cfg.data)
    given = given_depots(depots, cfg.segment.n_actions)
    scn = load_scenario(
        table.source.path,
        cfg,
        depots_path=given,
        replay_days=[day],
        table=table,
        cache=not in_memory(data),
    )
    drones = (
        fleet if isinstance(fleet, Fleet) else load_fleet(fleet, scn.depots, cfg.sim.drones, cfg)
    )
    check_window(window, cfg)  # as the planner would, naming the option as its caller does
    plan, reqs = plan_one_window(scn, day, window, drones, pol, done)
    scope = DayScope.of(reqs)
    drop_report(progress, scn.table, data_name(data))
    day_scope(progress, scope, cfg)
    unservable_requests(progress, day, reqs, scn.depots.xy, list(dict.fromkeys(drones.models())))
    long_flights(progress, drones.types, cfg)
    stops, routes = route_tables(scn, reqs, [plan], drones, method)
    meta = _meta(scn, cfg, pol, method, day, window, plan, given, drones)
    written: list[Path] = []
    if out is not None:
        with folder_lock(out):
            _clear_window(Path(out), route_file_paths(Path(out), fmt, geojson), report)
            with output_set() as files:
                written = write_route_files(files, Path(out), stops, routes, meta, fmt, geojson)
            if report:  # from the files just written, as `marops report` reads them
                from ..report import write_reports

                written += write_reports(Path(out), scn.depots)
    stops, routes = with_meta(stops, meta), with_meta(routes, meta)
    return PlannedWindow(plan, reqs, drones, stops, routes, meta, written, scn.table.report, scope)


WINDOW_OUTPUTS = (
    "stops.parquet",
    "routes.parquet",
    "stops.json",
    "routes.json",
    "routes.geojson",
    "report.html",
)
"""What a planned window's folder may hold (docs/outputs.md)."""


def _clear_window(folder: Path, writes: list[Path], report: bool) -> None:
    """Before a window's files go into ``folder``: remove an earlier run's outputs that
    this run does not write again (route files of the other format, a map or a page not
    asked for now), so none is taken for this run's. Only files marops wrote go, and
    none this run reads (``--delivered`` an earlier window's stops file there)."""
    from ..io.ownership import remove_ours

    keep = [*writes, folder / "report.html"] if report else writes
    remove_ours(folder / name for name in WINDOW_OUTPUTS if folder / name not in keep)


def _meta(
    scn: Any,
    cfg: PlannerConfig,
    pol: Any,
    method: str,
    day: dt.date,
    window: int,
    plan: WindowPlan,
    depots: Path | Depots,
    fleet: Fleet,
) -> dict[str, Any]:
    """The route files' metadata: the run's identity, the window and its solution."""
    from ..io import run_meta

    return run_meta(
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
            "depots_file": depots_record(depots),
            "fleet": fleet.describe(cfg.energy),
        },
        stamp=False,
    )
