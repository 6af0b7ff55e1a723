"""``marops evaluate``: compare methods over held-out days, sweep settings, plot."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from ..methods import reference_names
from . import options as o
from .common import (
    STATE,
    begin,
    emit_json,
    guarded,
    info,
    protect_inputs,
    show_table,
    stopped,
    table,
    warn,
)
from .progress import Terminal

if TYPE_CHECKING:
    import pyarrow as pa

    from ..app.evaluate import EvaluateConfig, EvaluationResult


@guarded
@o.takes_options("evaluate")
def evaluate_command(
    data: o.Data,
    out: o.OutFolder,
    methods: Annotated[
        str | None,
        typer.Option(
            "--methods",
            help=f"Methods to compare, comma-separated: {o.METHOD_NAMES} (docs/method.md §7) "
            f"[default: every one this build can run but the references {reference_names()}].",
        ),
    ] = None,
    dates: Annotated[
        str | None, typer.Option("--dates", help="Days to replay: 0820,0821 or 0820..0827.")
    ] = None,
    split: Annotated[
        str | None,
        typer.Option(
            "--split",
            help="test: the last 20 % of the file's dates; train: the rest [default: test].",
        ),
    ] = None,
    repeats: Annotated[
        int, typer.Option("--repeats", help="Runs per day (seed + r), at most 1000.")
    ] = 1,
    drones: Annotated[
        str | None, typer.Option("--drones", help="Fleet sizes: 4,8,16 [default: 8].")
    ] = None,
    alpha: Annotated[
        str | None, typer.Option("--alpha", help="Trade-off weights: 0.2,0.5,0.8 [default: 0.5].")
    ] = None,
    frontier: Annotated[
        bool,
        typer.Option(
            "--frontier",
            help="Sweep α over 0.2,0.3,0.5,0.7,0.8,0.9 and write each method's "
            "delay-energy-delivered frontier (frontier.csv; the report's chart).",
        ),
    ] = False,
    coverage: Annotated[
        str | None,
        typer.Option("--coverage", help="Flying coverage densities: 0.25,0.5 [default: 0.25]."),
    ] = None,
    n_depots: Annotated[
        str | None,
        typer.Option("--n-depots", help="Numbers of service areas: 8,16,32 [default: 16]."),
    ] = None,
    workers: o.Workers = 2,
    scheduler: o.Scheduler = None,
    hubs: Annotated[
        Path | None,
        typer.Option(
            "--hubs",
            help="hubs.json from marops segment --hubs: evaluate every hub of the city "
            "(each with its own depots and fleet; rows keyed by hub) [default: as --area says].",
        ),
    ] = None,
    area: o.Area = None,
    city_drones: o.CityDrones = None,
    policy: Annotated[
        Path | None,
        typer.Option(
            "--policy",
            help="Trained actor for marops and squares (.pt, or its weights "
            ".safetensors with the sidecar beside) [default: the shipped one of the "
            "run's operating model].",
        ),
    ] = None,
    mappo_policy: Annotated[
        Path | None,
        typer.Option(
            "--mappo-policy", help="Trained MAPPO actor (.pt) [default: the shipped one]."
        ),
    ] = None,
    trust_actor: o.TrustActor = False,
    against: Annotated[
        str | None,
        typer.Option(
            "--against",
            help="Reference method: each method's per-day difference to it, with a bootstrap "
            "95 % CI, into paired.csv and a table; it joins the default --methods, and must "
            "be among methods listed with --methods.",
        ),
    ] = None,
    plots: Annotated[
        bool, typer.Option("--plot/--no-plot", help="Draw the figures (PNG) into --out.")
    ] = True,
    report: o.Report = False,
    seed: o.Seed = None,
    year: o.Year = None,
    strict: o.Strict = False,
    force: o.Force = False,
    config: o.Config = None,
    quiet: o.Quiet = False,
    as_json: o.Json = False,
    *,
    options: dict[str, Any],
) -> None:
    """Compare methods on held-out days (paper Table III); sweep flags given several values."""
    data = begin(data, quiet=quiet, as_json=as_json, force=force)
    # The library (pyarrow, matplotlib, the planner) loads here, so `marops --help` stays fast.
    from ..app.options import evaluate_config

    sweep, outputs = _sweep_and_outputs(
        out, scheduler, (alpha, drones, coverage, n_depots, frontier), (against, plots, report)
    )
    protect_inputs(outputs, [data, config, policy, mappo_policy, hubs])
    run = evaluate_config(
        config,
        options,
        dates=dates,
        split=split,
        hubs=hubs,
        methods=methods,
        **sweep,
        repeats=repeats,
        workers=workers,
        scheduler=scheduler,
        policy=policy,
        mappo_policy=mappo_policy,
        against=against,
        plots=plots,
        force=force,
        report=report,
    )
    _show(_run(data, run, out))


def _run(data: Path, run: EvaluateConfig, out: Path) -> EvaluationResult:
    """The evaluation, with its progress on the terminal; stopped (Ctrl-C, SIGTERM), one
    line saying what the folder keeps."""
    from ..app.evaluate import evaluate

    try:
        return evaluate(data, run, out=out, progress=Terminal(remaining=True))
    except KeyboardInterrupt as exc:
        stopped(exc, "; ".join(getattr(exc, "__notes__", ())), "evaluate")


def _sweep_and_outputs(
    out: Path, scheduler: str | None, sweeps: tuple[Any, ...], files: tuple[Any, ...]
) -> tuple[dict[str, Any], list[Path]]:
    """Before any computing: refuse an output folder or a scheduler that cannot serve;
    the sweeps (``--alpha``, ``--drones``, ``--coverage``, ``--n-depots``, ``--frontier``)
    as :class:`~marops_cli.app.evaluate.EvaluateConfig` fields, and the files the run
    writes (with ``--against``, ``--plot``, ``--report``)."""
    from ..app.evaluate import check_out, output_files, sweep_fields

    check_out(out)
    if scheduler is not None:
        from ..workers.cluster import check_scheduler

        check_scheduler(scheduler)
    sweep = sweep_fields(*sweeps)
    against, plots, report = files
    return sweep, output_files(out, sweep=sweep, against=against, plots=plots, report=report)


def _show(res: Any) -> None:
    """The evaluation's tables, the files written, and with --json the summary; over
    fewer than ten days a warning that they establish no difference."""
    from ..evaluate.paired import comparison_warning

    _print_tables(res.summary)
    if res.frontier is not None:
        _print_frontier(res.frontier)
    if res.paired is not None:
        _print_paired(res.paired, res.summary)
    if (few := comparison_warning(res.summary, res.paired)) is not None:
        warn(few)
    info(f"wrote {', '.join(str(p) for p in res.files)}")
    if STATE["json"]:
        _emit_json(res)


def _emit_json(res: EvaluationResult) -> None:
    """``--json``: the files written, the days, the summary and the paired comparison."""
    emit_json(
        {
            "command": "evaluate",
            "files": [str(p) for p in res.files],
            "days": [d.isoformat() for d in res.days],
            "summary": res.summary.to_pylist(),
            "paired": res.paired.to_pylist() if res.paired is not None else None,
        }
    )


def _print_paired(paired: pa.Table, summary: pa.Table) -> None:
    """One row per setting (named by its values: ``α=0.3``), method and metric."""
    from ..evaluate.paired import verdict
    from ..evaluate.tables import setting_label

    rows = paired.to_pylist()
    if not rows:
        return
    t = table(f"paired against {rows[0]['against']}: per-day difference, bootstrap 95 % CI")
    cols = ("setting", "method", "metric", "days", "mean diff", "95 % CI", "days better", "verdict")
    for col in cols:
        t.add_column(
            col,
            justify="right" if col in ("days", "mean diff", "95 % CI", "days better") else "left",
        )
    labels = {s: setting_label(summary, s) for s in {r["setting"] for r in rows}}
    for r in rows:
        t.add_row(
            labels[r["setting"]],
            r["method"],
            r["metric"],
            str(r["days"]),
            f"{r['mean_diff']:+.4g}",
            f"[{r['ci_low']:+.4g}, {r['ci_high']:+.4g}]",
            f"{r['days_better']}/{r['days']}",
            verdict(r),
        )
    show_table(t, keys=3)


def _print_frontier(front: pa.Table) -> None:
    """Each method's operating point per α, and which point dominates it."""
    t = table(
        'Frontier over α (docs/outputs.md, "Frontier"): a dominated point is never the one to pick'
    )
    for name in ("drones", "method", "α", "delivered", "delay h", "energy MJ", "kJ/parcel"):
        t.add_column(name, justify="left" if name == "method" else "right")
    t.add_column("dominated by")
    for r in front.to_pylist():
        t.add_row(
            str(r["drones"]),
            r["method"],
            f"{r['alpha']:g}",
            f"{r['delivered']:.1f}",
            f"{r['avg_delay_h']:.3f}",
            f"{r['energy_kj'] / 1e3:.2f}",
            f"{r['energy_per_parcel_kj']:.1f}",
            r["dominated_by"] or "-",
        )
    show_table(t)


def _print_tables(summary: pa.Table) -> None:
    """One Table III per setting."""
    from ..evaluate import table3
    from ..evaluate.report import setting_title

    for s in sorted(set(summary.column("setting").to_pylist())):
        methods, body = table3(summary, s)
        t = table(setting_title(summary, s))
        t.add_column("metric")
        for m in methods:
            t.add_column(m, justify="right")
        for label, cells in body:
            t.add_row(label, *cells)
        show_table(t)
