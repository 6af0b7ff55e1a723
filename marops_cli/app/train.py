"""Train: learn the flight-range actor with MAPPO (paper Alg. 3) and write it.

One call reads every city, splits each by date, segments each on its training days,
builds the training scenarios (docs/method.md §6), trains (resuming from the
checkpoint beside the actor) and writes the TorchScript actor, its sidecar, the
checkpoint and the training curve.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..config import PlannerConfig
from .progress import SILENT, Progress

if TYPE_CHECKING:
    from ..rl.config import TrainConfig

__all__ = ["Note", "TrainResult", "TrainSetup", "actor_files", "train"]


@dataclass(frozen=True)
class TrainSetup:
    """What to train on and how: the planner config, the training hyperparameters, and
    the scenarios' days, area counts and fleet sizes."""

    planner: PlannerConfig
    train: TrainConfig
    train_days: Sequence[dt.date] | None = None
    """Training days of the first file (the rest are held out); None: its first 80 %."""
    n_depots: Sequence[int] = ()
    """Area counts to train on; empty: the config's."""
    drones: Sequence[int] = ()
    """Fleet sizes to train on; empty: the config's."""
    spares: Sequence[int] = ()
    """Batteries per depot to train on (the landing actor); empty: the config's."""
    batteries: Sequence[str] = ()
    """Battery regimes to train on (the landing actor; names of
    :data:`~marops_cli.config.BATTERY_PRESETS`, not with ``spares``); empty: the config's."""
    resume: bool = True
    """Continue from the checkpoint beside the actor when there is one."""
    command: str | None = None
    """The command that trains, for the sidecar."""
    data_origin: str | None = None
    """How the data was made, for the sidecar."""


@dataclass(frozen=True)
class TrainResult:
    """The trained actor's files and what the run measured."""

    actor: Path
    """The TorchScript actor (``NAME.pt``); the landing actor's weights file
    (``NAME.safetensors``)."""
    files: list[Path]
    """The actor, its weights (``NAME.safetensors``), its sidecar (``NAME.json``), its
    curve (``NAME.curve.png``) when drawn, and the checkpoint (``NAME.ckpt``)."""
    sidecar: dict[str, Any]
    """The sidecar document (docs/method.md §6)."""

    @property
    def curve(self) -> list[dict[str, float]]:
        """Mean return, delay and energy per update (the sidecar's ``learning_curve``)."""
        return list(self.sidecar.get("learning_curve") or [])

    @property
    def heldout(self) -> dict[str, Any] | None:
        """The exported actor's held-out evaluation, with the baselines' (per method:
        mean energy, delay, daily combined cost, ...); None without held-out days."""
        return self.sidecar.get("heldout")

    @property
    def training_time_s(self) -> float:
        return float(self.sidecar["training_time_s"])


class Note(str):
    """A progress text that also carries the numbers it states (``fields``), for a
    renderer that draws them (a reward column, the time left); any other renderer shows
    it as the text it is."""

    fields: dict[str, Any]

    def __new__(cls, text: str, **fields: Any) -> Note:
        note = super().__new__(cls, text)
        note.fields = fields
        return note


def actor_files(out: Path, algorithm: str = "ppo") -> list[Path]:
    """Every file a run writes for the actor ``out``: ``NAME.pt``, ``.safetensors``,
    ``.json``, ``.ckpt``, ``.curve.png``; the landing actor (``es``) only
    ``NAME.safetensors``, ``.json`` and ``.ckpt``."""
    if algorithm == "es":
        return [out.with_suffix(x) for x in (".safetensors", ".json", ".ckpt")]
    suffixes = (".safetensors", ".json", ".ckpt", ".curve.png")
    return [out, *(out.with_suffix(x) for x in suffixes)]


def train(
    data: str | Path | Sequence[str | Path],
    setup: TrainSetup,
    out: str | Path,
    *,
    progress: Progress = SILENT,
) -> TrainResult:
    """Train on ``data`` (one file, or several cities) as ``setup`` says and write the
    actor ``out`` (a ``.pt``) with its sidecar, checkpoint and curve beside it.

    ``progress`` hears the run's start (a :class:`Note` with the days, scenarios and
    first episode), one ``advance`` per episode (a :class:`Note` with the update's
    reward, delay, energy and entropy on an update's last), and each held-out
    evaluation.
    """
    from ..io.atomic import check_unheld
    from ..io.ownership import check_outputs, register_inputs
    from ..rl.data import load_training_data
    from ..rl.train import train_actor

    out = Path(out)
    register_inputs([data] if isinstance(data, str | Path) else list(data))
    check_unheld(out)  # not into a folder another run holds
    check_outputs(actor_files(out, setup.train.algorithm))  # before the long work
    td = load_training_data(
        data,
        setup.planner,
        setup.train,
        list(setup.train_days) if setup.train_days is not None else None,
        n_depots=setup.n_depots,
        drones=setup.drones,
        spares=setup.spares,
        batteries=setup.batteries,
    )
    from ..workers.pool import workers_note

    if (note := workers_note(setup.train.workers)) is not None:
        progress.warning(note)
    report = _Report(progress)
    try:
        written = train_actor(
            td,
            out,
            resume=setup.resume,
            command=setup.command,
            data_origin=setup.data_origin,
            on_event=report,
        )
    finally:
        if report.started:
            progress.finish()
    side = written.sidecar
    if setup.train.algorithm == "es":
        files = actor_files(out, "es")
        return TrainResult(files[0], files, side)
    from ..errors import switch
    from ..policies.installation import record_path

    if not written.recorded:  # a record that is a link, a pipe, read-only
        progress.warning(
            f"{record_path()}: this installation's record of trained actors was not "
            f"written (a symbolic link, a pipe or no write access): {out.name} loads by "
            f"its weights file {out.with_suffix('.safetensors').name}, or with "
            f"{switch('trust_actor')}"
        )
    files = [out, out.with_suffix(".safetensors"), out.with_suffix(".json")]
    if side.get("learning_curve"):  # drawn from it (rl/export.py)
        files.append(out.with_suffix(".curve.png"))
    files.append(out.with_suffix(".ckpt"))
    return TrainResult(out, files, side)


class _Report:
    """The training loop's events as :class:`Progress` calls."""

    def __init__(self, progress: Progress) -> None:
        self.progress = progress
        self.started = False
        self.episode = 0

    def __call__(self, e: dict[str, Any]) -> None:
        kind = e["kind"]
        if kind == "start":
            self.episode = int(e["episode"])
            self.progress.message(Note(_start_line(e), **e))
            self.progress.start("episodes", int(e["episodes"]) - self.episode, "episodes")
            self.started = True
        elif kind == "update":
            for _ in range(int(e["episode"]) - self.episode - 1):
                self.progress.advance()
            self.episode = int(e["episode"])
            self.progress.advance(Note(_update_line(e), **e))
        elif kind == "eval":
            self.progress.message(Note(_eval_line(e), **e))


def _start_line(e: dict[str, Any]) -> str:
    what = "resuming at" if e["resumed"] else "starting at"
    scn = int(e.get("scenarios", 1))
    where = f" in {scn} scenarios ({e.get('files', 1)} files)" if scn > 1 else ""
    return (
        f"training on {e['train_days']} days{where}, held out {e['eval_days']}; "
        f"{what} episode {e['episode']} of {e['episodes']}"
    )


def _update_line(e: dict[str, Any]) -> str:
    if "cost" in e:  # the landing actor's generation (rl/es.py)
        return (
            f"episode {e['episode']}: generation {e['generation']}, "
            f"cost {e['cost']:.3f} (1: the best rule's)"
        )
    return (
        f"episode {e['episode']}: reward {e['reward']:.3f}, "
        f"day delay {e['delay_h']:.0f} h, "
        f"energy {e['energy_kj']:.0f} kJ, entropy {e['entropy']:.3f}"
    )


def _eval_line(e: dict[str, Any]) -> str:
    if "cost" in e:
        a, b = e["methods"]["marops"], e["methods"]["best rule"]
        return (
            f"episode {e['episode']}: held-out cost {e['cost']:.3f}; day J "
            f"{a['objective_j_mj']:.1f} MJ against the best rule's {b['objective_j_mj']:.1f}, "
            f"energy {a['mean_energy_kj']:.0f} against {b['mean_energy_kj']:.0f} kJ/drone"
        )
    parts = [
        f"{m} {v['mean_energy_kj']:.0f} kJ {v['avg_delay_h']:.2f} h "
        f"daily cost {v['daily_combined_cost']:.3f}"
        for m, v in e["methods"].items()
    ]
    return f"episode {e['episode']}: held-out " + "; ".join(parts)
