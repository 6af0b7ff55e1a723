"""``marops train``: learn the flight-range actor with MAPPO (paper Alg. 3) and export it."""

from __future__ import annotations

import re
import shlex
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from ..errors import InputError, spelled
from ..io.ownership import allow_replacing_foreign
from . import options as o
from .common import (
    console,
    guarded,
    is_terminal,
    one_line,
    protect_inputs,
    require_input,
    show_table,
    table,
    warn,
)

if TYPE_CHECKING:
    from ..config import PlannerConfig
    from ..rl.config import TrainConfig


class _Reporter:
    """Training's progress: a bar with the reward on a terminal, plain log lines with the
    time left otherwise (cron, CI), from the numbers the app's progress notes carry."""

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

    def message(self, text: str) -> None:
        e = getattr(text, "fields", {})
        if e.get("kind") == "start":
            self.first, self.total = int(e["episode"]), int(e["episodes"])
            self.t0 = time.perf_counter()
        console.print(one_line(text))

    def warning(self, text: str) -> None:
        warn(spelled(text))  # an option named by its flag (marops_cli/errors.py)

    def start(self, label: str, total: int, unit: str) -> None:
        if not is_terminal():
            return
        self.progress = Progress(
            TextColumn(label),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("reward {task.fields[reward]}"),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
            console=console,
            transient=True,
        )
        self.task = self.progress.add_task(
            "train", total=self.total, completed=self.first, reward="-"
        )
        self.progress.start()

    def advance(self, text: str = "") -> None:
        e = getattr(text, "fields", None)
        if e is None:  # an episode of an update before its last: nothing to show yet
            return
        if self.progress is not None:
            shown = e["reward"] if "reward" in e else e["cost"]
            self.progress.update(self.task, completed=e["episode"], reward=f"{shown:.3f}")
        elif e["episode"] % self.every < 8 or e["episode"] <= 8 or "cost" in e:
            eta = self.eta_s(int(e["episode"]))
            left = f", about {eta / 60:.1f} min left" if eta is not None else ""
            typer.echo(f"[{time.perf_counter() - self.t0:7.0f}s] {text}{left}", err=True)

    def finish(self) -> None:
        if self.progress is not None:
            self.progress.stop()
            self.progress = None


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
    from ..config import ascii_number

    if text is None:
        return {}
    if text.strip().lower() == "fixed":
        return {"alpha_range": None}
    # LOW,HIGH; or LOW-HIGH, split at a dash after a digit (not an exponent's: 1e-3-0.9)
    parts = text.split(",") if "," in text else re.split(r"(?<=[0-9.])\s*-", text)
    try:
        lo, hi = (ascii_number(x, float) for x in parts)
    except ValueError:
        msg = f"--alpha-range expects LOW-HIGH (e.g. 0.1-0.9) or fixed, got {text!r}"
        raise InputError(msg) from None
    return {"alpha_range": (lo, hi)}


@guarded
@o.takes_options("train")
def train_command(
    data: Annotated[
        list[Path],
        typer.Argument(
            metavar="DATA", help="LaDe delivery exports (CSV or Parquet); several: several cities."
        ),
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            help="Actor to write: policies/NAME.pt, and beside it its weights "
            "(.safetensors), sidecar (.json), curve (.curve.png) and checkpoint (.ckpt); "
            "--algorithm es: NAME.safetensors, its sidecar and checkpoint.",
        ),
    ],
    days: Annotated[
        str | None,
        typer.Option(
            "--dates",
            help="Training days (0801..0824); the rest are held out [default: the first 80 %].",
        ),
    ] = None,
    episodes: Annotated[int, typer.Option("--episodes", help="Training episodes (days).")] = 2000,
    method: Annotated[
        str, typer.Option("--method", help="marops (destinations) or mappo (plans directly).")
    ] = "marops",
    algorithm: Annotated[
        str,
        typer.Option(
            "--algorithm",
            help="ppo (the recurrent actor, paper) or es (the landing actor of an operating "
            "model; writes NAME.safetensors + .json) [default: ppo].",
            show_default=False,
        ),
    ] = "ppo",
    energy_weight: Annotated[
        float,
        typer.Option(
            "--energy-weight",
            help="--algorithm es: cost of each share of energy per drone above the day's best "
            "rule's (docs/method.md §6.1) [default: 1.0].",
            show_default=False,
        ),
    ] = 1.0,
    energy_slack: Annotated[
        float,
        typer.Option(
            "--energy-slack",
            help="--algorithm es: share of energy per drone above the day's best rule's that "
            "costs nothing; --energy-weight prices the rest (0..1) [default: 0.0].",
            show_default=False,
        ),
    ] = 0.0,
    loss_weight: Annotated[
        float,
        typer.Option(
            "--loss-weight",
            help="--algorithm es: extra cost of each share of J above the day's best rule's, "
            "so that a day lost weighs more than a day won (docs/method.md §6.1) "
            "[default: 2.0].",
            show_default=False,
        ),
    ] = 2.0,
    energy_per: Annotated[
        str,
        typer.Option(
            "--energy-per",
            help="--algorithm es: what --energy-weight compares, energy per drone or per "
            "delivered parcel: drone or parcel [default: drone].",
            show_default=False,
        ),
    ] = "drone",
    features: Annotated[
        str,
        typer.Option(
            "--features",
            help="--algorithm es: the landing actor's features, basic (16 weights), context "
            "(22: fleet density, load, stranding and α too) or rules (25: the flow rule's "
            "landings too; docs/method.md §6.1) [default: basic].",
            show_default=False,
        ),
    ] = "basic",
    init: Annotated[
        Path | None,
        typer.Option(
            "--init",
            help="--algorithm es: a landing actor (.safetensors) whose weights training "
            "starts from, new features at 0 [default: the backlog score].",
        ),
    ] = None,
    train_weights: Annotated[
        str,
        typer.Option(
            "--train-weights",
            help="--algorithm es: the weights training moves, all, or new: only those of "
            "the features --init's actor lacks [default: all].",
            show_default=False,
        ),
    ] = "all",
    spares: Annotated[
        str | None,
        typer.Option(
            "--spares",
            help="--algorithm es: batteries per depot to train on (1,2,4) [default: the config's].",
        ),
    ] = None,
    rules: Annotated[
        str | None,
        typer.Option(
            "--rules",
            help="--algorithm es: the rules each training day's best rule is chosen from "
            "(ops-global,backlog,rebalance) [default: all five references].",
        ),
    ] = None,
    batteries: Annotated[
        str | None,
        typer.Option(
            "--batteries",
            help="--algorithm es: battery regimes to train on, of scarce, default, ample "
            "(spares, chargers and charging power; not with --spares) [default: the config's].",
        ),
    ] = None,
    workers: Annotated[
        int, typer.Option("--workers", help="Rollout processes, 1 to 256, at most 4 per CPU run.")
    ] = 2,
    resume: Annotated[
        bool, typer.Option("--resume/--no-resume", help="Continue from NAME.ckpt if present.")
    ] = True,
    alpha: o.Alpha = None,
    drones: Annotated[
        str | None,
        typer.Option(
            "--drones",
            envvar="MAROPS_DRONES",
            help="Fleet size, or sizes to train on (8,16) [default: 8].",
        ),
    ] = None,
    n_depots: Annotated[
        str | None,
        typer.Option("--n-depots", help="Depots, or counts to train on (16,25) [default: 16]."),
    ] = None,
    alpha_range: Annotated[
        str | None,
        typer.Option(
            "--alpha-range",
            help="Episodes draw α from LOW-HIGH (the actor observes α); 'fixed': the --alpha "
            "only [default: 0.1-0.9].",
        ),
    ] = None,
    obs_version: Annotated[
        int,
        typer.Option(
            "--obs-version",
            help="Observation version of the flight-range actor (--method marops): 4, or 5 "
            "(adds the drone's own type: payload, battery, speed; for mixed fleets) "
            "[default: 4].",
            show_default=False,
        ),
    ] = 4,
    seed: Annotated[int, typer.Option("--seed", help="Training seed; same seed, same actor.")] = 0,
    eval_days: Annotated[
        int,
        typer.Option("--eval-days", help="Held-out days per scenario in each evaluation (0: all)."),
    ] = 0,
    eval_every: Annotated[
        int,
        typer.Option(
            "--eval-every",
            help="Episodes between held-out evaluations [default: 200].",
            show_default=False,
        ),
    ] = 200,
    data_origin: Annotated[
        str | None,
        typer.Option("--data-origin", help="How DATA was made (e.g. the marops synth command)."),
    ] = None,
    year: o.Year = None,
    config: o.Config = None,
    force: o.Force = False,
    *,
    options: dict[str, Any],
) -> None:
    """Train the flight-range actor (MAPPO), or the landing actor (--algorithm es), on
    training days; write the actor and its sidecar."""
    from ..app.train import TrainSetup, actor_files
    from ..app.train import train as run_training

    _check_args(data, out, algorithm, method, obs_version)
    allow_replacing_foreign(force)
    protect_inputs(actor_files(out, algorithm), [*data, config, init])  # before the long work
    cfg, scenarios = _planner(config, options, (drones, n_depots, spares, batteries), days)
    tcfg = _train_config(
        algorithm=algorithm,
        es_energy_weight=energy_weight,
        es_energy_slack=energy_slack,
        es_energy_basis=energy_per,
        **_landing_fields(features, init, train_weights, algorithm, rules),
        es_loss_weight=loss_weight,
        method=method,
        episodes=episodes,
        seed=seed,
        workers=workers,
        eval_days_per_scenario=eval_days,
        eval_every=eval_every,
        obs_version=obs_version,
        **_alpha_range(alpha_range),
    )
    setup = TrainSetup(
        cfg, tcfg, **scenarios, resume=resume, command=_command(), data_origin=data_origin
    )
    res = run_training(data, setup, out, progress=_Reporter(tcfg.checkpoint_every))
    console.print(one_line(f"wrote {', '.join(map(str, res.files))} ({res.training_time_s:.0f} s)"))
    if res.heldout:
        _print_heldout(res.heldout)


def _landing_fields(
    features: str, init: Path | None, train_weights: str, algorithm: str, rules: str | None
) -> dict[str, Any]:
    """The landing actor's training settings of ``--features``, ``--init``,
    ``--train-weights`` and ``--rules`` (as :func:`_alpha_range` gives α's)."""
    return {
        "landing_features": features,
        "landing_start": _start_weights(init, algorithm, (features, train_weights)),
        "landing_train": train_weights,
        "es_rules": None if rules is None else _listed(rules),
    }


def _listed(text: str) -> list[str]:
    """The names of a comma-separated flag (``--rules``, ``--batteries``), as typed and in
    order (repeats kept: ``es_rules``' check refuses them), empty ones left out."""
    return [t.strip() for t in text.split(",") if t.strip()]


def _start_weights(
    init: Path | None, algorithm: str, training: tuple[str, str]
) -> list[float] | None:
    """The weights of the landing actor file ``init`` (``--init``), read as data only;
    ``training``: ``--features`` and ``--train-weights``, which the actor must leave
    room for."""
    features, train_weights = training
    if init is None:
        if train_weights == "new":
            raise InputError(
                "--train-weights new trains the features --init's actor lacks: pass --init"
            )
        return None
    if algorithm != "es":
        raise InputError("--init is the landing actor's (--algorithm es)")
    from ..data.jsonfile import read_json
    from ..policies.landing import FEATURE_SETS, load_landing_actor

    if init.suffix != ".safetensors" or not init.is_file():
        raise InputError("--init must name a landing actor's .safetensors file", file=init)
    sidecar = init.with_suffix(".json")
    weight = load_landing_actor(init, read_json(sidecar, "actor sidecar"), sidecar).weight
    if features not in FEATURE_SETS:
        return weight.tolist()  # the bad --features is named as the settings are checked
    size = FEATURE_SETS[features].start.size
    if weight.size > size:
        raise InputError(
            f"its {weight.size} weights do not fit --features {features} ({size} weights)",
            file=init,
        )
    if weight.size == size and train_weights == "new":
        raise InputError(
            f"it has every weight of --features {features}: --train-weights new would train none",
            file=init,
        )
    return weight.tolist()


def _command() -> str | None:
    """The command as typed, for the sidecar."""
    return "marops " + shlex.join(sys.argv[1:]) if sys.argv else None


def _planner(
    config: Path | None,
    options: dict[str, Any],
    sizes: tuple[str | None, str | None, str | None, str | None],
    days: str | None,
) -> tuple[PlannerConfig, dict[str, Any]]:
    """The planner config of the options (the first of several fleet sizes or depot
    counts), and the scenarios trained on: the ``sizes`` (``--drones``, ``--n-depots``,
    ``--spares``, ``--batteries``) and the days."""
    from ..app.options import planner_config
    from ..config import override
    from ..data.dates import parse_days

    drones, n_depots, spares, batteries = sizes
    fleets, depot_counts = _sizes(drones, "--drones"), _sizes(n_depots, "--n-depots")
    cfg = planner_config(
        config,
        **options,
        drones=fleets[0] if fleets else None,
        n_depots=depot_counts[0] if depot_counts else None,
    )
    spare_counts = _sizes(spares, "--spares")
    # Every value in range before any file is read, named by its flag: the scenarios
    # apply them only once the data is read and segmented.
    for flag, key, values in (
        ("--drones", "sim__drones", fleets),
        ("--n-depots", "segment__n_depots", depot_counts),
        ("--spares", "ops__batteries_per_depot", spare_counts),
    ):
        for value in values:
            override(cfg, {key: flag}, **{key: value})
    train_days = parse_days(days, cfg.data.year, "--dates") if days is not None else None
    scenarios = {"drones": fleets, "n_depots": depot_counts, "spares": spare_counts}
    return cfg, {**scenarios, "batteries": _regimes(batteries, spares), "train_days": train_days}


def _regimes(text: str | None, spares: str | None) -> list[str]:
    """``--batteries``' names of :data:`~marops_cli.config.BATTERY_PRESETS` (``"scarce,ample"``
    -> ``["scarce", "ample"]``), refused with ``--spares`` or an unknown name."""
    from ..config import BATTERY_PRESETS, check_battery_regimes

    names = _listed(text or "")
    if text is not None and not names:
        raise InputError(f"--batteries expects names of {', '.join(BATTERY_PRESETS)}, got {text!r}")
    check_battery_regimes(names, spares is not None, "--batteries")
    return names


def _check_args(data: list[Path], out: Path, algorithm: str, method: str, obs_version: int) -> None:
    """Refuse, before any work, standard input or a missing file for DATA, an ``--out``
    of the wrong kind and an ``--obs-version`` the actor would ignore."""
    for path in data:
        if str(path) == "-":  # training reads each city's file several times
            raise InputError("train reads files (one per city), not standard input (-)")
        require_input(path)
    if out.suffix != (".safetensors" if algorithm == "es" else ".pt"):
        want = "a .safetensors file (--algorithm es)" if algorithm == "es" else "a .pt file"
        raise InputError(f"--out must name {want} (the sidecar goes beside it)", file=out)
    if obs_version != 4 and (method == "mappo" or algorithm == "es"):  # it was ignored
        who = "--algorithm es (the landing actor)" if algorithm == "es" else "--method mappo"
        raise InputError(f"--obs-version is the recurrent marops actor's; {who} has its own")


_FLAGS = {
    "es_energy_weight": "energy-weight",
    "es_energy_slack": "energy-slack",
    "es_energy_basis": "energy-per",
    "landing_features": "features",
    "landing_train": "train-weights",
    "es_loss_weight": "loss-weight",
    "es_rules": "rules",
    "eval_days_per_scenario": "eval-days",
}
"""The flag of a training setting whose name differs from it."""


def _train_config(**fields: Any) -> TrainConfig:
    """The training hyperparameters of the flags; a bad value names its flag."""
    from pydantic import ValidationError

    from ..config import option_error
    from ..rl.config import TrainConfig  # deferred: torch loads only for this command

    try:
        return TrainConfig(**fields)
    except ValidationError as exc:
        raise option_error(exc, TrainConfig, _flag) from None


def _flag(name: str) -> str:
    """The flag (without ``--``) of the training setting ``name``."""
    return _FLAGS.get(name, name.replace("_", "-"))


def _print_heldout(heldout: dict[str, Any]) -> None:
    """The exported actor's held-out days beside the baselines' (mean over days)."""
    from ..sim.metrics import metric_specs

    first = next(iter(heldout["methods"].values()))
    names = ("mean_energy_kj", "avg_delay_h", "daily_combined_cost", "objective_j_mj")
    specs = metric_specs(*[n for n in names if n in first])
    t = table("held-out days (mean over days)")
    t.add_column("method", justify="left")
    for s in specs:
        t.add_column(s.header, justify="right")
    for m, v in heldout["methods"].items():
        t.add_row(m, *[s.day_fmt.format(v[s.name]) for s in specs])
    show_table(t)
