"""Evaluate: compare methods over held-out days, sweep settings, write tables and figures.

One call reads the data, segments it, runs every job (day x method x setting x repeat)
over worker processes or a Dask cluster, and summarises the rows (paper Table III,
docs/method.md §7-9). Given an output folder, it keeps each finished job in
``OUT/jobs/`` as it finishes, resumes from there, and writes ``results.parquet``,
``summary.csv``, ``summary.md``, the figures and ``paired.csv`` (docs/outputs.md,
"Evaluation").
"""

from __future__ import annotations

import datetime as dt
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..config import OpsConfig, PlannerConfig, count
from ..data.table import LadeTable
from ..errors import InputError, option, switch
from .inputs import in_memory
from .messages import drop_report, late_orders, long_flights
from .progress import SILENT, Progress

if TYPE_CHECKING:
    import pyarrow as pa

    from ..evaluate import Evaluation, Job, Prepared
    from ..evaluate.dataset import JobStore
    from ..segment.hubs import Hub

__all__ = [
    "JOBS",
    "output_files",
    "EvaluateConfig",
    "EvaluationResult",
    "actor_paths",
    "default_methods",
    "evaluate",
    "method_list",
    "sweep_fields",
]

JOBS = "jobs"
"""The jobs dataset in the output folder: one file per finished replay (docs/outputs.md)."""
PAIRED = "paired.csv"
"""The paired comparison against ``against``, when one is asked for."""


def output_files(
    out: Path,
    *,
    sweep: Mapping[str, Sequence[Any] | None],
    against: str | None,
    plots: bool,
    report: bool,
) -> list[Path]:
    """The files an evaluation into ``out`` writes, and only those, checked before any
    work: ``paired.csv`` with ``against``, a figure per swept flag (``sweep``: the
    :func:`sweep_fields`) and the others with ``plots`` (evaluate/report.py names them),
    ``report.html`` with ``report``. A file of one's own by another of these names
    stays where it is."""
    from ..evaluate.frontier import FRONTIER_FILE
    from ..evaluate.report import ACTIONS, TABLES, UNFAIRNESS

    swept = [f"{flag}.png" for flag, values in sweep.items() if values and len(set(values)) > 1]
    figures = [*swept, UNFAIRNESS, ACTIONS] if plots else []
    names = [*TABLES, *figures, *[PAIRED] * (against is not None)]
    names += [FRONTIER_FILE] * (len(set(sweep.get("alpha") or ())) > 1)
    return [out / n for n in names] + [out / "report.html"] * report


@dataclass(frozen=True)
class EvaluateConfig:
    """What to compare, over which days and settings, and where to run it."""

    planner: PlannerConfig
    methods: Sequence[str] | None = None
    """Methods to compare; None: :func:`default_methods`."""
    alpha: Sequence[float] | None = None
    drones: Sequence[int] | None = None
    coverage: Sequence[float] | None = None
    depots_n: Sequence[int] | None = None
    """Values to sweep (every combination is a setting); None keeps the config's value."""
    days: Sequence[dt.date] | None = None
    """Days to replay; None: the ``split``'s."""
    split: str = "test"
    """``test``: the last 20 % of the file's dates; ``train``: the rest."""
    repeats: int = 1
    workers: int = 2
    scheduler: str | None = None
    """A Dask scheduler's address, ``local`` for a cluster of ``workers`` processes on
    this machine; None: local worker processes."""
    hubs: Sequence[Hub] | None = None
    """Every hub of a city as its own study area (docs/method.md §1.1); None: one area."""
    actors: dict[str, Path] = field(default_factory=dict)
    """Policy kind (``learned``, ``direct``) -> trained actor replacing the shipped one."""
    against: str | None = None
    """Reference method of the paired comparison (``paired``); None: none. Without a
    list of ``methods`` it joins the default ones (``myopic``, a reference, is not
    among them); with one, it must be in it."""
    plots: bool = True
    force: bool = False
    """Clear another evaluation's jobs found in the output folder, and the outputs marops
    built from them."""
    report: bool = False
    """Write report.html into the output folder (docs/report.md)."""


@dataclass(frozen=True)
class EvaluationResult:
    """What an evaluation produced, in memory, and where its files are."""

    results: pa.Table
    """One row per setting x method x day x repeat (docs/outputs.md, "Evaluation")."""
    summary: pa.Table
    """Mean and std per setting and method."""
    paired: pa.Table | None
    """Each method's per-day difference to ``against``, with a bootstrap 95 % CI."""
    days: list[dt.date]
    files: list[Path]
    """The files written (none without an output folder)."""
    folder: Path | None

    @property
    def frontier(self) -> pa.Table | None:
        """Each method's operating point per α, dominated ones marked (``frontier.csv``,
        docs/outputs.md "Frontier"); None without two values of α."""
        from ..evaluate.frontier import frontier_table

        return frontier_table(self.results)


def evaluate(
    data: str | Path | LadeTable,
    config: EvaluateConfig,
    *,
    out: Path | None = None,
    progress: Progress = SILENT,
) -> EvaluationResult:
    """Run the evaluation ``config`` describes on ``data`` (a LaDe file or its table);
    with ``out``, keep its jobs there as they finish (resuming the ones already there)
    and write its tables and figures."""
    from ..evaluate import expand_settings, prepare
    from ..io.ownership import check_outputs, register_inputs
    from ..workers.pool import check_workers
    from .report import check_report

    check_report(config.report and out is not None)
    check_workers(config.workers)
    if config.scheduler is not None:
        from ..workers.cluster import check_scheduler

        check_scheduler(config.scheduler)
    from ..policies.registry import actor_files

    # Never an output: the data, and every file of an actor given (sidecar included).
    register_inputs([data, *(f for a in config.actors.values() for f in actor_files(a))])
    if out is not None:  # before any work: a folder, no file marops did not write
        check_out(out)
        from ..evaluate.dataset import check_jobs_folder
        from ..io.atomic import check_free

        check_jobs_folder(out / JOBS)

        check_free(out)  # no other run writes there, nor above it or inside it
        sweep = {
            "alpha": config.alpha,
            "drones": config.drones,
            "coverage": config.coverage,
            "depots_n": config.depots_n,
        }
        check_outputs(
            output_files(
                out, sweep=sweep, against=config.against, plots=config.plots, report=config.report
            )
        )
    cfg = config.planner
    settings = expand_settings(
        cfg,
        alpha=config.alpha,
        drones=config.drones,
        coverage=config.coverage,
        depots_n=config.depots_n,
    )
    actors = {k: Path(v) for k, v in config.actors.items()}
    methods = (
        list(config.methods)
        if config.methods is not None
        else default_methods(actors, trust=cfg.sim.trust_actor, ops=cfg.ops)
    )
    if config.against is not None and config.against not in methods:
        if config.methods is not None:  # a list given: the reference is one of it
            listed = option("methods")
            raise InputError(
                f"{option('against')} {config.against!r} is not among {listed} "
                f"({', '.join(methods)}); add it to {listed}"
            )
        methods.append(config.against)  # the default methods and the reference
    if config.against is not None and set(methods) == {config.against}:
        listed = option("methods")
        raise InputError(
            f"{option('against')} {config.against!r} leaves no other method of {listed} "
            f"({', '.join(methods)}) to compare with it; add one to {listed}"
        )
    if config.scheduler is None and config.workers > 1:
        from ..evaluate.runner import worker_modules
        from ..sim.scenario import loads_actor
        from ..workers import warm_up

        # The workers' fork server imports the planner (and torch for an actor) while
        # this process reads the file and segments it.
        warm_up(worker_modules(actor=any(loads_actor(m, paper=cfg.ops.paper) for m in methods)))
    prep = prepare(
        data,
        cfg,
        methods,
        settings,
        days=config.days,
        split=config.split,
        repeats=config.repeats,
        actors=actors,
        hubs=config.hubs,
        cache=not in_memory(data),  # a table in memory: no depots cache written
    )
    drop_report(progress, prep.source, prep.source.source.name)
    from ..sim.fleet import DEFAULT_TYPE, DroneType

    long_flights(progress, [DroneType(DEFAULT_TYPE, cfg.energy)], cfg)  # its drones are cfg's
    if prep.hubs and config.hubs is None:
        from ..segment.hubs import outside_warning

        far = outside_warning(
            prep.source,
            prep.hubs,
            prep.days,
            cfg.data.hub_min_share,
            history=prep.history,
            unplaced=prep.unplaced,
            n_depots=max(s.depots_n for s in prep.settings),
        )
        if far is not None:
            progress.warning(far)
    if prep.hubs:
        from ..segment.hubs import hub_owner

        late_orders(progress, prep.source, prep.days, cfg, hub_owner(prep.source, prep.hubs) >= 0)
    if prep.skipped:
        left = ", ".join(d.isoformat() for d in prep.skipped)
        where = "any hub's square" if prep.hubs else "the study area"
        progress.warning(
            f"left out {left} of the {config.split} split: nothing due inside {where} "
            "within service hours"
        )
    from ..workers.pool import workers_note

    if (note := workers_note(config.workers, config.scheduler, len(prep.jobs))) is not None:
        progress.warning(note)
    progress.message(_plan_line(prep, config))
    if out is None:
        ev = _run(prep, config, None, progress)
        paired = _paired(ev, config.against)
        results = _with_meta(ev.results, prep)  # as results.parquet carries it
        return EvaluationResult(results, ev.summary, paired, prep.days, [], None)
    return _evaluate_into(out, prep, config, progress)


def _with_meta(results: pa.Table, prep: Prepared) -> pa.Table:
    """``results`` carrying the ``marops`` metadata of ``results.parquet`` (the package,
    config, input and settings), in memory as in the file."""
    from ..evaluate.report import evaluation_meta
    from ..io.tables import with_meta

    return with_meta(results, evaluation_meta(prep))


def check_out(out: Path) -> None:
    """--out must be a folder this user can write (or create), and no evaluation's jobs
    folder nor inside one, found out before anything runs and without writing anything."""
    if out.exists() and not out.is_dir():
        raise InputError(f"{option('out')} must be a folder; this is a file", file=out)
    probe = out.absolute()
    while not probe.exists():  # the nearest existing folder must let us create the rest
        probe = probe.parent
    if not probe.is_dir():
        raise InputError(f"{option('out')} cannot be created: {probe} is a file", file=out)
    if not os.access(probe, os.W_OK | os.X_OK):
        raise InputError(f"{option('out')} is not writable ({probe})", file=out)
    from ..io.ownership import check_outside_jobs

    check_outside_jobs(out)  # not among another evaluation's jobs


def default_methods(
    actors: dict[str, Path], *, trust: bool = False, ops: OpsConfig | None = None
) -> list[str]:
    """Every method this build can run (learned ones need an actor; ``trust``:
    ``cfg.sim.trust_actor``), but the references (stay, myopic), which are compared only
    when asked for. An actor given in ``actors`` must load: its methods are never
    skipped."""
    from ..evaluate import check_methods
    from ..methods import METHODS, method

    chosen = []
    for m in METHODS:
        try:
            check_methods([m], actors, trust=trust, ops=ops)
        except InputError:
            if method(m).policy in actors:  # --policy or --mappo-policy: a typo is an error
                raise
            continue  # the default list skips what cannot run; a listed method errors
        if method(m).in_default_evaluation:
            chosen.append(m)
    return chosen


def method_list(text: str | None) -> list[str] | None:
    """``"marops, greedy"`` -> ``["marops", "greedy"]``; None: :func:`default_methods`. An
    empty item (``stay,,greedy``, a trailing comma) is refused, as the sweeps' are: a
    typo never changes what is evaluated without a word."""
    if text is None:
        return None
    names = [m.strip() for m in text.split(",")]
    if text.strip() and not all(names):
        raise InputError(
            f"{option('methods')} expects method names separated by commas, got {text!r}"
        )
    return [m for m in names if m]


def sweep_fields(
    alpha: str | None,
    drones: str | None,
    coverage: str | None,
    n_depots: str | None,
    frontier: bool = False,
) -> dict[str, Any]:
    """The sweep options' values (``"0.2,0.5"``; None: the config's) as
    :class:`EvaluateConfig` fields; a bad value names its option. ``frontier`` sweeps α
    over :data:`~marops_cli.evaluate.frontier.FRONTIER_ALPHAS` (not with ``alpha``)."""
    from ..evaluate import parse_values
    from ..evaluate.frontier import FRONTIER_ALPHAS

    if frontier and alpha is not None:
        raise InputError(f"give at most one of {option('alpha')} or {switch('frontier')}")
    if frontier:
        alpha = ",".join(f"{a:g}" for a in FRONTIER_ALPHAS)
    return {
        "alpha": parse_values(alpha, float, option("alpha")),
        "drones": parse_values(drones, int, option("drones")),
        "coverage": parse_values(coverage, float, option("coverage")),
        "depots_n": parse_values(n_depots, int, option("n_depots")),
    }


def actor_paths(policy: str | Path | None, mappo_policy: str | Path | None) -> dict[str, Path]:
    """:attr:`EvaluateConfig.actors` of the options: ``policy`` replaces the shipped actor
    of the learned methods (marops, squares), ``mappo_policy`` the direct one (mappo)."""
    kinds = (("learned", "policy", policy), ("direct", "mappo_policy", mappo_policy))
    for _, name, path in kinds:
        if path is not None and not Path(path).name:  # '.', '/': no actor file's name
            raise InputError(f"{option(name)} names no actor file, got {str(path)!r}")
    return {kind: Path(path) for kind, _, path in kinds if path is not None}


def _plan_line(prep: Prepared, config: EvaluateConfig) -> str:
    """``evaluate: 3 methods x 1 setting x 4 days x 1 repeat = 12 replays, on 2 workers``."""
    from ..workers.pool import local_workers

    workers, scheduler = local_workers(config.workers), config.scheduler
    where = (
        count(workers, "worker")
        if scheduler is None
        else f"a local Dask cluster of {count(workers, 'worker')}"
        if scheduler == "local"
        else f"the Dask scheduler at {scheduler}"
    )
    hub_note = f" over {count(len(prep.hubs), 'hub')} (hub-days with requests)" if prep.hubs else ""
    return (
        f"evaluate: {count(len(prep.methods), 'method')} x "
        f"{count(len(prep.settings), 'setting')} x {count(len(prep.days), 'day')} x "
        f"{count(prep.repeats, 'repeat')}{hub_note} = {count(len(prep.jobs), 'replay')}, "
        f"on {where}"
    )


def _evaluate_into(
    out: Path, prep: Prepared, config: EvaluateConfig, progress: Progress
) -> EvaluationResult:
    """Run ``prep`` keeping its jobs in ``out``, then write its tables and figures there."""
    from ..evaluate import write_outputs
    from ..evaluate.dataset import JobStore
    from ..evaluate.runner import run_identity
    from ..io.atomic import folder_lock

    with folder_lock(out):  # one run at a time in a folder; stale temporaries go
        store = JobStore(out / JOBS, prep, run_identity(prep), built=_built_files(out))
        store.open(force=config.force)  # this run's finished jobs, or an error for another's
        if store.resumed:
            n = len(prep.jobs)
            progress.message(f"resumed: {store.resumed} of {n} replays from {store.root}")
        try:
            ev = _run(prep, config, store, progress)
        except KeyboardInterrupt as exc:  # Ctrl-C or SIGTERM: the caller says what is kept
            kept = store.kept()
            exc.add_note(
                f"{kept} of {len(prep.jobs)} replays are kept in {store.root}: run "
                "the same command again to resume"
                if kept
                else f"no replay of {len(prep.jobs)} had finished: nothing is kept"
            )
            raise
        files = write_outputs(out, prep, ev.results, ev.summary, plots=config.plots)
        paired = _paired(ev, config.against)
        if paired is not None:
            files.append(_write_paired(out, paired))
        if config.report:
            from ..report import write_reports

            files += write_reports(out)
    return EvaluationResult(_with_meta(ev.results, prep), ev.summary, paired, prep.days, files, out)


def _built_files(out: Path) -> list[Path]:
    """Every output an evaluation may build from its jobs in ``out``, whatever its flags:
    ``--force`` removes another run's (marops's own only) with its jobs, so that no
    figure or paired.csv of that run stays beside this run's tables."""
    from ..evaluate.settings import SWEEP_FLAGS

    every = {flag: [0, 1] for flag in SWEEP_FLAGS}
    return output_files(out, sweep=every, against="any", plots=True, report=True)


def _run(
    prep: Prepared, config: EvaluateConfig, store: JobStore | None, progress: Progress
) -> Evaluation:
    """Run the jobs, one ``advance`` per replay (the ones resumed first, at once)."""
    from ..evaluate import evaluate_jobs

    def done(n: int, total: int, job: Job) -> None:
        s = prep.settings[job.setting]
        hub = f"hub {job.hub} " if prep.hubs else ""
        progress.advance(
            f"evaluate {n}/{total}: {hub}{job.day.isoformat()} {job.method} "
            f"alpha={s.alpha:g} drones={prep.drones(job)} coverage={s.coverage:g} "
            f"depots={s.depots_n} repeat {job.repeat}"
        )

    progress.start("evaluate", len(prep.jobs), "replays")
    try:
        for _ in range(store.resumed if store is not None else 0):
            progress.advance()
        return evaluate_jobs(prep, config.workers, done, store, config.scheduler)
    finally:
        progress.finish()


def _paired(ev: Evaluation, against: str | None) -> pa.Table | None:
    """Every method against ``against``, day by day (None without one)."""
    if against is None:
        return None
    from ..evaluate.paired import paired_table

    return paired_table(ev.results, against)


def _write_paired(out: Path, paired: pa.Table) -> Path:
    """``paired.csv``."""
    from ..io import output_set
    from ..io.tables import write_csv

    with output_set() as files:
        files.write_with(out / PAIRED, lambda p: write_csv(paired, p))
    return out / PAIRED
