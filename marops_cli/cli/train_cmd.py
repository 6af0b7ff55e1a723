"""``marops train``: learn the flight-range actor with MAPPO (paper Alg. 3) and export it."""

from __future__ import annotations

import shlex
import sys
import time
from pathlib import Path
from typing import Annotated, Any

import typer
from pydantic import ValidationError
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from ..data.dates import parse_days
from ..errors import InputError
from ..io.atomic import allow_replacing_foreign, check_replaceable
from . import options as o
from .common import (
    console,
    guarded,
    is_terminal,
    make_config,
    refuse_overwriting_inputs,
    require_input,
    show_table,
    table,
)


def _eval_line(ev: dict[str, Any]) -> str:
    parts = [
        f"{m} {v['mean_energy_kj']:.0f} kJ {v['avg_delay_h']:.2f} h "
        f"daily cost {v['daily_combined_cost']:.3f}"
        for m, v in ev["methods"].items()
    ]
    return f"episode {ev['episode']}: held-out " + "; ".join(parts)


class _Reporter:
    """Progress bar on a terminal, plain log lines otherwise (cron, CI)."""

    def __init__(self, every: int) -> None:
        self.every = every
        self.progress: Progress | None = None
        self.task: Any = None
        self.t0 = time.perf_counter()
        self.first = 0  # the episode this run started at (a resumed run starts later)
        self.total = 0

    def eta_s(self, episode: int) -> float | None:
        """Seconds left at this run's pace so far (None before the first episode)."""
        done = episode - self.first
        if done <= 0:
            return None
        return (time.perf_counter() - self.t0) / done * max(0, self.total - episode)

    def __call__(self, e: dict[str, Any]) -> None:
        kind = e["kind"]
        if kind == "start":
            self.first, self.total = int(e["episode"]), int(e["episodes"])
            self.t0 = time.perf_counter()
            what = "resuming at" if e["resumed"] else "starting at"
            scn = int(e.get("scenarios", 1))
            where = f" in {scn} scenarios ({e.get('files', 1)} files)" if scn > 1 else ""
            console.print(
                f"training on {e['train_days']} days{where}, held out {e['eval_days']}; "
                f"{what} episode {e['episode']} of {e['episodes']}"
            )
            if is_terminal():
                self.progress = Progress(
                    TextColumn("episodes"),
                    BarColumn(),
                    MofNCompleteColumn(),
                    TextColumn("reward {task.fields[reward]}"),
                    TimeElapsedColumn(),
                    TimeRemainingColumn(),
                    console=console,
                    transient=True,
                )
                self.task = self.progress.add_task(
                    "train", total=e["episodes"], completed=e["episode"], reward="-"
                )
                self.progress.start()
        elif kind == "update":
            line = (
                f"episode {e['episode']}: reward {e['reward']:.3f}, "
                f"day delay {e['delay_h']:.0f} h, "
                f"energy {e['energy_kj']:.0f} kJ, entropy {e['entropy']:.3f}"
            )
            if self.progress is not None:
                self.progress.update(self.task, completed=e["episode"], reward=f"{e['reward']:.3f}")
            elif e["episode"] % self.every < 8 or e["episode"] <= 8:
                eta = self.eta_s(int(e["episode"]))
                left = f", about {eta / 60:.1f} min left" if eta is not None else ""
                typer.echo(f"[{time.perf_counter() - self.t0:7.0f}s] {line}{left}", err=True)
        elif kind == "eval":
            console.print(_eval_line(e))

    def close(self) -> None:
        if self.progress is not None:
            self.progress.stop()


def _sizes(text: str | None, flag: str) -> list[int]:
    """``"8,16"`` -> ``[8, 16]`` (the sweep parser of ``evaluate``), each at least 1."""
    from ..evaluate.settings import parse_values  # deferred: it loads the simulator

    out = parse_values(text, int, flag) or []
    if out and min(out) < 1:
        raise InputError(f"{flag} expects positive whole numbers, got {text!r}")
    return out


def _alpha_range(text: str | None) -> dict[str, Any]:
    """``TrainConfig`` fields of ``--alpha-range``: ``"0.1-0.9"`` or ``"0.1,0.9"`` ->
    (0.1, 0.9); ``"fixed"`` -> None (the ``--alpha`` only); unset -> none (the default)."""
    if text is None:
        return {}
    if text.strip().lower() == "fixed":
        return {"alpha_range": None}
    parts = text.replace(",", "-").split("-")
    try:
        lo, hi = (float(x) for x in parts)
    except ValueError:
        msg = f"--alpha-range expects LOW-HIGH (e.g. 0.1-0.9) or fixed, got {text!r}"
        raise InputError(msg) from None
    return {"alpha_range": (lo, hi)}


@guarded
def train(
    data: Annotated[
        list[Path],
        typer.Argument(help="LaDe delivery exports (CSV or Parquet); several: several cities."),
    ],
    out: Annotated[Path, typer.Option("--out", help="Actor to write: policies/NAME.pt (+ .json).")],
    days: Annotated[
        str | None,
        typer.Option(
            "--dates",
            help="Training days (0801..0824); the rest are held out (default: first 80 %).",
        ),
    ] = None,
    episodes: Annotated[int, typer.Option("--episodes", help="Training episodes (days).")] = 2000,
    method: Annotated[
        str, typer.Option("--method", help="marops (destinations) or mappo (plans directly).")
    ] = "marops",
    workers: Annotated[int, typer.Option("--workers", help="Rollout processes.")] = 2,
    resume: Annotated[
        bool, typer.Option("--resume/--no-resume", help="Continue from NAME.ckpt if present.")
    ] = True,
    alpha: o.Alpha = None,
    drones: Annotated[
        str | None,
        typer.Option(
            "--drones", envvar="MAROPS_DRONES", help="Fleet size, or sizes to train on (8,16) [8]."
        ),
    ] = None,
    n_depots: Annotated[
        str | None, typer.Option("--n-depots", help="Depots, or counts to train on (16,25) [16].")
    ] = None,
    alpha_range: Annotated[
        str | None,
        typer.Option(
            "--alpha-range",
            help="Episodes draw α from LOW-HIGH (the actor observes α) [0.1-0.9]; "
            "'fixed': the --alpha only.",
        ),
    ] = None,
    obs_version: Annotated[
        int,
        typer.Option(
            "--obs-version",
            help="Observation version of the flight-range actor: 4, or 5 (adds the drone's own "
            "type: payload, battery, speed; for mixed fleets) [4].",
        ),
    ] = 4,
    seed: Annotated[int, typer.Option("--seed", help="Training seed; same seed, same actor.")] = 0,
    eval_days: Annotated[
        int,
        typer.Option("--eval-days", help="Held-out days per scenario in each evaluation (0: all)."),
    ] = 0,
    data_origin: Annotated[
        str | None,
        typer.Option("--data-origin", help="How DATA was made (e.g. the marops synth command)."),
    ] = None,
    year: o.Year = None,
    config: o.Config = None,
    force: o.Force = False,
) -> None:
    """Train the flight-range actor (MAPPO) on training days; write TorchScript + sidecar."""
    from ..rl.config import TrainConfig  # deferred: torch loads only for this command
    from ..rl.train import train as run_training

    for path in data:
        require_input(path)
    if out.suffix != ".pt":
        raise InputError("--out must name a .pt file (the sidecar goes beside it)", file=out)
    outputs = [out, *(out.with_suffix(x) for x in (".json", ".ckpt", ".curve.png"))]
    for path in data:
        refuse_overwriting_inputs(outputs, data=path, config=config)
    allow_replacing_foreign(force)
    check_replaceable(outputs)
    fleets, depot_counts = _sizes(drones, "--drones"), _sizes(n_depots, "--n-depots")
    cfg = make_config(
        config,
        data__year=year,
        plan__alpha=alpha,
        sim__drones=fleets[0] if fleets else None,
        segment__n_depots=depot_counts[0] if depot_counts else None,
    )
    try:
        tcfg = TrainConfig(
            method=method,  # type: ignore[arg-type]
            episodes=episodes,
            seed=seed,
            workers=workers,
            eval_days_per_scenario=eval_days,
            obs_version=obs_version,  # type: ignore[arg-type]
            **_alpha_range(alpha_range),
        )
    except ValidationError as exc:
        err = exc.errors()[0]
        raise InputError(f"invalid option --{err['loc'][0]}: {err['msg']}") from None
    train_days = parse_days(days, cfg.data.year) if days else None
    command = "marops " + shlex.join(sys.argv[1:]) if sys.argv else None
    rep = _Reporter(tcfg.checkpoint_every)
    try:
        side = run_training(
            data,
            cfg,
            tcfg,
            out,
            train_days=train_days,
            n_depots=depot_counts,
            drones=fleets,
            resume=resume,
            command=command,
            data_origin=data_origin,
            on_event=rep,
        )
    finally:
        rep.close()
    console.print(f"wrote {out} and {out.with_suffix('.json')} ({side['training_time_s']:.0f} s)")
    if side.get("heldout"):
        from ..sim.metrics import metric_specs

        specs = metric_specs("mean_energy_kj", "avg_delay_h", "daily_combined_cost")
        t = table("held-out days (mean over days)")
        t.add_column("method", justify="left")
        for s in specs:
            t.add_column(s.header, justify="right")
        for m, v in side["heldout"]["methods"].items():
            t.add_row(m, *[s.day_fmt.format(v[s.name]) for s in specs])
        show_table(t)
