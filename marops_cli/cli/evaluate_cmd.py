"""``marops evaluate``: compare methods over held-out days, sweep settings, plot."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from ..data.dates import parse_days
from ..errors import InputError
from ..io.atomic import allow_replacing_foreign
from ..methods import reference_names
from . import options as o
from .common import (
    STATE,
    console,
    emit_json,
    guarded,
    info,
    is_terminal,
    make_config,
    print_drop_report,
    refuse_overwriting_inputs,
    require_input,
    set_output,
    show_table,
    stopped,
    table,
    warn,
)

if TYPE_CHECKING:
    from ..evaluate import Evaluation, Job, Prepared
    from ..evaluate.dataset import JobStore


@guarded
def evaluate(
    data: o.Data,
    out: Annotated[Path, typer.Option("--out", help="Output folder.")],
    methods: Annotated[
        str | None,
        typer.Option(
            "--methods",
            help=f"Methods to compare, comma-separated: {o.METHOD_NAMES} (docs/method.md §7) "
            f"(default: every one this build can run but the references {reference_names()}).",
        ),
    ] = None,
    dates: Annotated[
        str | None, typer.Option("--dates", help="Days to replay: 0820,0821 or 0820..0827.")
    ] = None,
    split: Annotated[
        str | None,
        typer.Option(
            "--split",
            help="test: the last 20 % of the file's dates; train: the rest (default test).",
        ),
    ] = None,
    repeats: Annotated[int, typer.Option("--repeats", min=1, help="Runs per day (seed + r).")] = 1,
    drones: Annotated[str | None, typer.Option("--drones", help="Fleet sizes: 4,8,16 [8].")] = None,
    alpha: Annotated[
        str | None, typer.Option("--alpha", help="Trade-off weights: 0.2,0.5,0.8 [0.5].")
    ] = None,
    coverage: Annotated[
        str | None, typer.Option("--coverage", help="Flying coverage densities: 0.25,0.5 [0.25].")
    ] = None,
    n_depots: Annotated[
        str | None, typer.Option("--n-depots", help="Numbers of service areas: 8,16,32 [16].")
    ] = None,
    workers: Annotated[
        int,
        typer.Option(
            "--workers", min=1, help="Worker processes (with --scheduler local: the cluster's)."
        ),
    ] = 2,
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler",
            help="Run the jobs on a Dask cluster: its scheduler's address (tcp://HOST:8786), "
            "or local for a cluster of --workers processes on this machine; needs "
            "pip install 'marops[cluster]' (README.md, Sweeps on a cluster).",
        ),
    ] = None,
    hubs: Annotated[
        Path | None,
        typer.Option(
            "--hubs",
            help="hubs.json from marops segment --hubs: evaluate every hub of the city "
            "(each with its own depots and fleet; rows keyed by hub) [one study area].",
        ),
    ] = None,
    policy: Annotated[
        Path | None,
        typer.Option(
            "--policy",
            help="Trained actor (.pt) for marops and squares (default: the shipped one).",
        ),
    ] = None,
    mappo_policy: Annotated[
        Path | None,
        typer.Option(
            "--mappo-policy", help="Trained MAPPO actor (.pt) (default: the shipped one)."
        ),
    ] = None,
    against: Annotated[
        str | None,
        typer.Option(
            "--against",
            help="Reference method: each method's per-day difference to it, with a bootstrap "
            "95 % CI, into paired.csv and a table.",
        ),
    ] = None,
    plots: Annotated[
        bool, typer.Option("--plot/--no-plot", help="Draw the figures (PNG) into --out.")
    ] = True,
    seed: o.Seed = None,
    year: o.Year = None,
    strict: o.Strict = False,
    force: o.Force = False,
    config: o.Config = None,
    quiet: o.Quiet = False,
    as_json: o.Json = False,
) -> None:
    """Compare methods on held-out days (paper Table III); sweep flags given several values."""
    set_output(quiet, as_json)
    allow_replacing_foreign(force)
    # The library (pyarrow, matplotlib, the planner) loads here, so `marops --help` stays fast.
    from ..evaluate import expand_settings, parse_values, prepare, write_outputs

    require_input(data)
    _check_out(out)  # before any computing
    if scheduler is not None:
        from ..workers.cluster import require_distributed

        require_distributed()
    refuse_overwriting_inputs(
        [out / n for n in ("results.parquet", "summary.csv", "summary.md")],
        data=data,
        config=config,
        policy=policy,
        mappo_policy=mappo_policy,
        hubs=hubs,
    )
    cfg = make_config(config, data__year=year, data__strict=strict or None, sim__seed=seed)
    hub_list = None
    if hubs is not None:
        from ..segment.hubs import load_hubs

        hub_list = load_hubs(hubs, cfg.data)
    settings = expand_settings(
        cfg,
        alpha=parse_values(alpha, float, "--alpha"),
        drones=parse_values(drones, int, "--drones"),
        coverage=parse_values(coverage, float, "--coverage"),
        depots_n=parse_values(n_depots, int, "--n-depots"),
    )
    days = parse_days(dates, cfg.data.year) if dates else None
    if days and split:
        raise InputError("give at most one of --dates or --split")
    actors = {k: v for k, v in (("learned", policy), ("direct", mappo_policy)) if v is not None}
    chosen = _methods(methods, actors)
    if scheduler is None and workers > 1:
        from ..evaluate.runner import worker_modules
        from ..sim.jobs import loads_actor
        from ..workers import warm_up

        # The workers' fork server imports the planner (and torch for an actor) while
        # this process reads the file and segments it.
        warm_up(worker_modules(actor=any(loads_actor(m) for m in chosen)))
    if against is not None and against not in chosen:
        raise InputError(
            f"--against {against!r} is not among the methods compared ({', '.join(chosen)})"
        )
    prep = prepare(
        data,
        cfg,
        chosen,
        settings,
        days=days,
        split=split or "test",
        repeats=repeats,
        actors=actors,
        hubs=hub_list,
    )
    print_drop_report(prep.source.report, data.name)
    where = (
        f"{workers} workers"
        if scheduler is None
        else f"a local Dask cluster of {workers} workers"
        if scheduler == "local"
        else f"the Dask scheduler at {scheduler}"
    )
    hub_note = f" over {len(prep.hubs)} hubs (hub-days with requests)" if prep.hubs else ""
    info(
        f"evaluate: {len(prep.methods)} methods x {len(settings)} settings x "
        f"{len(prep.days)} days x {repeats} repeats{hub_note} = {len(prep.jobs)} replays, "
        f"on {where}"
    )
    from ..evaluate.dataset import JobStore
    from ..evaluate.runner import run_identity
    from ..io.atomic import folder_lock

    with folder_lock(out):  # one run at a time in a folder; stale temporaries go
        store = JobStore(out / JOBS, prep, run_identity(prep))
        store.open(force=force)  # this run's finished jobs, or an error for another run's
        if store.resumed:
            info(f"resumed: {store.resumed} of {len(prep.jobs)} replays from {store.root}")
        try:
            ev = _run(prep, workers, store, scheduler)
        except KeyboardInterrupt as exc:  # Ctrl-C or SIGTERM
            stopped(
                exc,
                f"{store.kept()} of {len(prep.jobs)} replays are kept in {store.root}: run "
                "the same command again to resume",
            )
        paths = write_outputs(out, prep, ev.results, ev.summary, plots=plots)
        paired = _paired(ev, against, out, paths)
    _print_tables(ev)
    if paired is not None:
        _print_paired(paired, len(prep.days))
    info(f"wrote {', '.join(str(p) for p in paths)}")
    if STATE["json"]:
        emit_json(
            {
                "command": "evaluate",
                "files": [str(p) for p in paths],
                "days": [d.isoformat() for d in prep.days],
                "summary": ev.summary.to_pylist(),
                "paired": paired.to_pylist() if paired is not None else None,
            }
        )


def _paired(ev: Evaluation, against: str | None, out: Path, paths: list[Path]) -> Any:
    """``paired.csv``: every method against ``against``, day by day (None without one)."""
    if against is None:
        return None
    import pyarrow.csv as pacsv

    from ..evaluate.paired import paired_table
    from ..io import output_set

    table = paired_table(ev.results, against)
    with output_set() as files:
        files.write_with(out / "paired.csv", lambda p: pacsv.write_csv(table, str(p)))
    paths.append(out / "paired.csv")
    return table


def _print_paired(paired: Any, n_days: int) -> None:
    from ..evaluate.paired import MIN_DAYS, verdict

    rows = paired.to_pylist()
    if not rows:
        return
    if n_days < MIN_DAYS:
        warn(
            f"only {n_days} days back the paired comparison (fewer than {MIN_DAYS}): "
            "the intervals are wide and the verdicts fragile"
        )
    t = table(f"paired against {rows[0]['against']}: per-day difference, bootstrap 95 % CI")
    for col in ("setting", "method", "metric", "days", "mean diff", "95 % CI", "days better", ""):
        t.add_column(col, justify="left" if col in ("method", "metric", "") else "right")
    for r in rows:
        t.add_row(
            str(r["setting"]),
            r["method"],
            r["metric"],
            str(r["days"]),
            f"{r['mean_diff']:+.4g}",
            f"[{r['ci_low']:+.4g}, {r['ci_high']:+.4g}]",
            f"{r['days_better']}/{r['days']}",
            verdict(r),
        )
    show_table(t)


JOBS = "jobs"
"""The jobs dataset in the --out folder: one file per finished replay (docs/outputs.md)."""


def _check_out(out: Path) -> None:
    """--out must be a folder this user can write (or create), found out before anything
    runs and without writing anything."""
    if out.exists() and not out.is_dir():
        raise InputError("--out must be a folder; this is a file", file=out)
    probe = out.absolute()
    while not probe.exists():  # the nearest existing folder must let us create the rest
        probe = probe.parent
    if not probe.is_dir():
        raise InputError(f"--out cannot be created: {probe} is a file", file=out)
    if not os.access(probe, os.W_OK | os.X_OK):
        raise InputError(f"--out is not writable ({probe})", file=out)


def _methods(text: str | None, actors: dict[str, Path]) -> list[str]:
    """The listed methods, or every one this build can run (learned ones need an actor)."""
    from ..evaluate import check_methods
    from ..methods import METHODS, method

    if text is not None:
        return [m.strip() for m in text.split(",") if m.strip()]
    chosen = []
    for m in METHODS:
        try:
            check_methods([m], actors)
        except InputError:
            continue  # the default list skips what cannot run; a listed method errors
        if method(m).in_default_evaluation:  # the references (stay, myopic) are asked for
            chosen.append(m)
    return chosen


def _run(
    prep: Prepared, workers: int, store: JobStore | None = None, scheduler: str | None = None
) -> Evaluation:
    """Run the jobs with a progress bar on a terminal, one log line per replay otherwise."""
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from ..evaluate import evaluate as run_evaluation

    if not is_terminal() or STATE["quiet"] or STATE["json"]:

        def log(done: int, total: int, job: Job) -> None:
            s = prep.settings[job.setting]
            hub = f"hub {job.hub} " if prep.hubs else ""
            info(
                f"evaluate {done}/{total}: {hub}{job.day.isoformat()} {job.method} "
                f"alpha={s.alpha:g} drones={prep.drones(job)} coverage={s.coverage:g} "
                f"depots={s.depots_n} repeat {job.repeat}"
            )

        return run_evaluation(prep, workers, log, store, scheduler)
    progress = Progress(
        TextColumn("evaluate"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=console,
        transient=True,
    )
    resumed = store.resumed if store is not None else 0
    task = progress.add_task("replays", total=len(prep.jobs), completed=resumed)
    with progress:
        return run_evaluation(
            prep,
            workers,
            lambda done, total, job: progress.update(task, completed=done),
            store,
            scheduler,
        )


def _print_tables(ev: Evaluation) -> None:
    from ..evaluate import table3
    from ..evaluate.report import setting_title

    for s in sorted(set(ev.summary.column("setting").to_pylist())):
        methods, body = table3(ev.summary, s)
        t = table(setting_title(ev.summary, s))
        t.add_column("metric")
        for m in methods:
            t.add_column(m, justify="right")
        for label, cells in body:
            t.add_row(label, *cells)
        show_table(t)
