"""Training the landing actor on the day's return: evolution strategies (docs/method.md
§6.1, "The landing actor"; docs/decisions.md, "Learning where to land").

The landing actor (:class:`~marops_cli.policies.landing.LandingActor`) scores each
destination by ``weight · features`` and assigns the drones to landings jointly.
Training searches the 16 weights (22 with ``landing_features = "context"``, 25 with
``"rules"``) directly on the quantities the actor is judged by, from the ``backlog`` rule's
score (:data:`~marops_cli.policies.landing.JOINT_START`, ``CONTEXT_START``,
``RULES_START``) or from another actor's weights (``landing_start``, ``--init``; with
``landing_train = "new"`` only the weights of the features that actor lacks move):

* each training day is first replayed with the rules the actor must beat,
  :data:`RULES` (``ops-global``, ``backlog``, ``rebalance``, ``flow``, ``battery``; or
  those of ``es_rules``); the day's *best rule* is the one with the lowest day objective
  J (docs/method.md §8);
* each generation draws ``es_days`` training days (scenario, day, α from
  ``alpha_range``) and ``es_pairs`` directions ε ~ N(0, I), and replays every day with
  the weights w, w + σε and w − σε (antithetic pairs: the same days for every member,
  so the day's own difficulty cancels);
* a member's cost on a day is its J over the best rule's J, plus ``es_energy_weight`` ×
  the share by which its energy per drone (``es_energy_basis = "parcel"``: per delivered
  parcel) exceeds the best rule's by more than
  ``es_energy_slack`` (0 within it), plus ``es_loss_weight`` × the share by which its J
  exceeds the best rule's (:func:`day_cost`): a plan must not win by spending energy
  the best rule saves, nor by losing some days to win more on others; its cost is the
  mean over the days;
* w moves by ``es_step`` × Σ (rank(w − σε) − rank(w + σε)) ε / pairs (centred ranks of
  the costs, so one extreme day cannot dominate a step).

Every replay of a training day is one episode of the budget (``episodes``), the rules'
included; held-out evaluations are not.
Held-out evaluations every ``eval_every`` episodes score w the same way on the training
cities' held-out days and keep the best (``keep_best``). Every random stream derives
from ``(seed, stream, generation)`` and replays are deterministic, so a run gives the
same weights with any number of workers, and resumes from its checkpoint to the same end.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field, ValidationError

from .. import __version__
from ..config import MAX_EPISODES, override
from ..data.filemodel import FileModel, Whole, error_text
from ..data.jsonfile import read_json
from ..errors import InputError
from ..io.atomic import output_set
from ..methods import reference_rules
from ..policies.base import check_weight_range
from ..policies.landing import (
    FEATURE_SETS,
    LandingActor,
    extend_weights,
    operating_model,
)
from ..policies.registry import make_policy
from ..sim.metrics import day_metrics
from ..sim.replay import fly_day
from ..sim.state import default_fleet
from ..sim.step import WindowStep
from ..workers import LocalPool
from .data import (
    TrainData,
    edited_checkpoint,
    fingerprint,
    other_algorithm,
    other_run,
)
from .rollout import TrainScenario, WorkerContext, derive_seed

__all__ = ["RULES", "LandingTrainer", "day_cost", "landing_weights_bytes", "write_landing_actor"]

_STREAM_BATCH, _STREAM_NOISE = 11, 12
_CKPT_FORMAT = "marops-landing-ckpt/1"
Event = dict[str, Any]
_KEYS = ("objective_j_mj", "delivered_share", "mean_energy_kj", "avg_delay_h")
RULES = reference_rules()
"""The rules the landing actor must beat (method -> policy spec; the methods registered
as references, marops_cli/methods.py): each day's best of them is its reference."""
Day = tuple[int, int, float]
"""A replay's (scenario, day, α)."""


class _Reference(FileModel):
    noun: ClassVar[str] = "reference"
    j: float
    energy: float
    share: float


class _HeldOutRule(FileModel):
    noun: ClassVar[str] = "held-out rule"
    rule: str
    objective_j_mj: float
    delivered_share: float
    mean_energy_kj: float
    avg_delay_h: float


class _Step(FileModel):
    noun: ClassVar[str] = "history entry"
    episode: float
    generation: float
    cost: float


class _Evaluation(FileModel):
    noun: ClassVar[str] = "evaluation"
    episode: Whole
    cost: float
    methods: dict[str, dict[str, Any]]


class _Best(FileModel):
    noun: ClassVar[str] = "best"
    shape: ClassVar[str] = "the best evaluation {episode, cost, weight}"
    episode: Whole
    cost: float
    weight: list[float]


class _Checkpoint(FileModel):
    """A landing actor's training checkpoint (``NAME.ckpt``, JSON) as
    :meth:`LandingTrainer.save_checkpoint` writes it."""

    noun: ClassVar[str] = "landing actor's checkpoint"
    format: Literal["marops-landing-ckpt/1"]
    fingerprint: Any
    weight: list[float]
    generation: Whole = Field(ge=0, le=MAX_EPISODES)
    episode: Whole = Field(ge=0, le=2 * MAX_EPISODES)  # a run stops within a generation
    elapsed_s: float = Field(ge=0)
    reference: dict[str, _Reference]
    held_out_rules: list[_HeldOutRule]
    history: list[_Step]
    evals: list[_Evaluation]
    best: _Best | None


@dataclass(frozen=True)
class LandingDay:
    """Replay day ``day`` of scenario ``scenario`` (held-out when ``held_out``) at trade-off
    ``alpha`` with the landing actor of ``weight``, or (``weight`` None) with the rule of
    method ``rule``."""

    index: int
    weight: tuple[float, ...] | None
    scenario: int
    day: int
    alpha: float
    held_out: bool = False
    rule: str = "backlog"


@dataclass
class LandingWork:
    """The worker pool's work: replay a day, return its metrics (:data:`_KEYS`)."""

    ctx: WorkerContext

    preload = (__name__,)

    def setup(self) -> None:
        return None

    def refuse(self) -> str | None:
        return None

    def run(self, task: LandingDay) -> dict[str, float]:
        scn: TrainScenario = self.ctx.scenarios[task.scenario]
        cfg = override(scn.cfg, plan__alpha=task.alpha)
        if task.weight is None:
            policy = make_policy(RULES[task.rule])
        else:
            policy = LandingActor(np.array(task.weight))
        day = (scn.eval_days if task.held_out else scn.train_days)[task.day]
        how = WindowStep.of(policy, cfg)
        fleet = default_fleet(scn.depots, cfg.sim.drones)
        res = fly_day(day, scn.depots, fleet, policy, cfg, method="marops", how=how)
        m = day_metrics(res, how.model)
        return {k: float(m[k]) for k in _KEYS}


class LandingTrainer:
    """The weights, the rules' reference days and the progress of one run; :meth:`run`
    trains, :meth:`export` writes the actor."""

    def __init__(self, td: TrainData, out: Path, on_event: Callable[[Event], None] | None = None):
        self.td, self.tcfg, self.out = td, td.ctx.tcfg, Path(out)
        self.rules = list(self.tcfg.es_rules or RULES)
        """The rules each training day's best rule is chosen from (``es_rules``)."""
        self.ckpt = self.out.with_suffix(".ckpt")
        self.emit = on_event or (lambda e: None)
        models = {operating_model(s.cfg.ops) for s in td.ctx.scenarios}
        if "paper" in models:
            raise InputError(
                "the landing actor learns where parcels and batteries wait: train it under "
                "an operating model ([ops] in --config), not the paper's"
            )
        if len(models) > 1:
            raise InputError("every training scenario needs the same operating model")
        self.model = models.pop()
        start = FEATURE_SETS[self.tcfg.landing_features].start
        self.moves = np.ones(start.size, dtype=bool)
        """The weights training moves (``landing_train``)."""
        if self.tcfg.landing_start is not None:
            given = np.array(self.tcfg.landing_start)
            start = extend_weights(given, start.size)
            if self.tcfg.landing_train == "new":
                self.moves = extend_weights(np.ones(given.size), start.size) == 0
                if not self.moves.any():
                    raise InputError("the actor to start from has every weight: none to train")
        elif self.tcfg.landing_train == "new":
            raise InputError("training only the new weights needs an actor to start from (--init)")
        self.weight = start.astype(np.float64).copy()
        self.generation = self.episode = 0
        self.elapsed_s = 0.0
        self.reference: dict[str, dict[str, float]] = {}
        """Per training day ("scenario/day/alpha"), its best rule's J and energy."""
        self.held_out_rules: list[dict[str, Any]] = []
        """Each held-out day's best rule: its name and metrics (replayed once)."""
        self.history: list[dict[str, float]] = []
        self.evals: list[dict[str, Any]] = []
        self.best: dict[str, Any] | None = None

    # -- checkpoints -----------------------------------------------------------------
    def save_checkpoint(self) -> None:
        """Write ``NAME.ckpt`` (JSON) atomically."""
        state = {
            "format": _CKPT_FORMAT,
            "fingerprint": fingerprint(self.td),
            "weight": self.weight.tolist(),
            "generation": self.generation,
            "episode": self.episode,
            "elapsed_s": self.elapsed_s,
            "reference": self.reference,
            "held_out_rules": self.held_out_rules,
            "history": self.history,
            "evals": self.evals,
            "best": self.best,
        }
        with output_set() as files:
            files.write_json(self.ckpt, state)

    def load_checkpoint(self) -> bool:
        """Resume from ``NAME.ckpt`` when there is one; refuse one made differently."""
        if not self.ckpt.is_file():
            return False
        wrong = other_algorithm(self.ckpt, "es")
        if wrong is not None:
            raise wrong
        state = read_json(self.ckpt, "training checkpoint")
        if not isinstance(state, dict) or state.get("format") != _CKPT_FORMAT:
            raise InputError("not a landing actor's checkpoint; pass --no-resume", file=self.ckpt)
        now = json.loads(json.dumps(fingerprint(self.td)))
        mismatch = other_run(self.ckpt, state.get("fingerprint"), now)
        if mismatch is not None:
            raise mismatch
        self._restore(state)
        return True

    def _restore(self, state: dict[str, Any]) -> None:
        """The weights and progress of a checkpoint's ``state`` (:class:`_Checkpoint`);
        refused, naming the key, on one of another shape, before changing anything."""
        kind = "a landing actor's checkpoint"
        try:
            ckpt = _Checkpoint.model_validate(state)
        except ValidationError as exc:
            key, msg = error_text(exc, _Checkpoint)
            raise edited_checkpoint(self.ckpt, kind, f"{key}: {msg}" if key else msg) from None
        weight = np.array(ckpt.weight, dtype=np.float64)
        if weight.shape != self.weight.shape:
            raise edited_checkpoint(self.ckpt, kind, f"weight must be {self.weight.size} numbers")
        best = ckpt.best
        if best is not None:
            if len(best.weight) != weight.size:
                raise edited_checkpoint(
                    self.ckpt, kind, f"best.weight must be {weight.size} numbers"
                )
            if best.episode not in [e.episode for e in ckpt.evals]:
                raise edited_checkpoint(self.ckpt, kind, "best must be one of the evaluations")
        # The weights an actor file may hold, refused as there (policies/base.py):
        # training would otherwise go on from, and export, weights no run can fly.
        for key, w in (("weight", weight), ("best.weight", best.weight if best else [])):
            try:
                largest = float(np.abs(np.asarray(w, dtype=np.float64)).max(initial=0.0))
                check_weight_range(largest, self.ckpt, key)
            except InputError as exc:
                raise edited_checkpoint(self.ckpt, kind, f"{key} {exc.message}") from None
        self.weight = weight
        self.generation, self.episode, self.elapsed_s = (
            ckpt.generation,
            ckpt.episode,
            ckpt.elapsed_s,
        )
        # As written (the model checked them): the run appends to them and writes them back.
        self.reference = state["reference"]
        self.held_out_rules, self.history, self.evals = (
            state[k] for k in ("held_out_rules", "history", "evals")
        )
        self.best = state["best"]

    # -- the rules and the cost --------------------------------------------------------
    def _best_rules(
        self, workers: LocalPool, days: list[Day], held_out: bool = False
    ) -> list[dict[str, Any]]:
        """Each day's best rule (lowest J, the first of the run's rules on ties): its name
        and metrics. A rule's replay of a training day counts as an episode."""
        rules = self.rules
        pairs = [(d, r) for d in days for r in rules]
        rows = workers.results(
            [LandingDay(k, None, *d, held_out=held_out, rule=r) for k, (d, r) in enumerate(pairs)]
        )
        if not held_out:  # evaluations are not training episodes
            self.episode += len(rows)
        out = []
        for i in range(len(days)):
            part = dict(zip(rules, rows[i * len(rules) : (i + 1) * len(rules)], strict=True))
            name = min(part, key=lambda r: part[r]["objective_j_mj"])
            out.append({"rule": name, **part[name]})
        return out

    def _references(self, workers: LocalPool, days: list[Day]) -> list[dict[str, float]]:
        """The best rule's J and energy of each of ``days`` (replayed once per run)."""
        need = sorted({d for d in days if _key(d) not in self.reference})
        for d, best in zip(need, self._best_rules(workers, need), strict=True):
            self.reference[_key(d)] = _reference(best)
        return [self.reference[_key(d)] for d in days]

    def _cost(self, rows: list[dict[str, float]], refs: list[dict[str, float]]) -> float:
        """Mean over days of :func:`day_cost`."""
        t = self.tcfg
        return float(
            np.mean(
                [
                    day_cost(
                        r,
                        b,
                        t.es_energy_weight,
                        t.es_energy_slack,
                        t.es_loss_weight,
                        per_parcel=t.es_energy_basis == "parcel",
                    )
                    for r, b in zip(rows, refs, strict=True)
                ]
            )
        )

    # -- one generation ----------------------------------------------------------------
    def _batch(self) -> list[Day]:
        """The generation's (scenario, training day, α)."""
        t = self.tcfg
        rng = np.random.default_rng(derive_seed(t.seed, _STREAM_BATCH, self.generation))
        out = []
        for _ in range(t.es_days):
            j = int(rng.integers(len(self.td.ctx.scenarios)))
            i = int(rng.integers(len(self.td.ctx.scenarios[j].train_days)))
            a = self.td.ctx.scenarios[j].cfg.plan.alpha
            if t.alpha_range is not None:
                a = round(float(rng.uniform(*t.alpha_range)), 1)
            out.append((j, i, a))
        return out

    def _generation(self, workers: LocalPool) -> dict[str, float]:
        t = self.tcfg
        days = self._batch()
        refs = self._references(workers, days)
        rng = np.random.default_rng(derive_seed(t.seed, _STREAM_NOISE, self.generation))
        eps = rng.standard_normal((t.es_pairs, self.weight.size)) * self.moves
        members = [self.weight, *(self.weight + t.es_sigma * eps)]
        members += [*(self.weight - t.es_sigma * eps)]
        pairs = [(w, d) for w in members for d in days]
        tasks = [LandingDay(k, tuple(float(x) for x in w), *d) for k, (w, d) in enumerate(pairs)]
        rows = workers.results(tasks)
        n = len(days)
        cost = np.array([self._cost(rows[k * n : (k + 1) * n], refs) for k in range(len(members))])
        order = cost[1:].argsort(kind="stable").argsort(kind="stable")
        ranks = order / max(1, 2 * t.es_pairs - 1) - 0.5
        step = ((ranks[t.es_pairs :] - ranks[: t.es_pairs])[:, None] * eps).sum(axis=0)
        # Float32 weights, what the file stores: the exported actor flies as trained.
        moved = (self.weight + t.es_step * step / t.es_pairs).astype(np.float32)
        self.weight = moved.astype(np.float64)
        self.generation += 1
        self.episode += len(tasks)
        stats = {"episode": self.episode, "generation": self.generation, "cost": float(cost[0])}
        self.history.append({k: round(float(v), 5) for k, v in stats.items()})
        return stats

    def evaluate(self, workers: LocalPool) -> dict[str, Any] | None:
        """The current weights and each day's best rule on the held-out days: the training
        cost (below 1: better than the best rule) and the mean metrics of both."""
        cap = self.tcfg.eval_days_per_scenario
        days = [
            (j, i, s.cfg.plan.alpha)
            for j, s in enumerate(self.td.ctx.scenarios)
            for i in range(len(s.eval_days) if cap == 0 else min(cap, len(s.eval_days)))
        ]
        if not days:
            return None
        if not self.held_out_rules:  # the rules do not change: their days once
            self.held_out_rules = self._best_rules(workers, days, held_out=True)
        best = self.held_out_rules
        w = tuple(float(x) for x in self.weight)
        mine = workers.results([LandingDay(k, w, *d, held_out=True) for k, d in enumerate(days)])
        refs = [_reference(b) for b in best]
        cost = self._cost(mine, refs)
        ev = {
            "episode": self.episode,
            "cost": round(cost, 5),
            "methods": {
                name: {k: round(float(np.mean([r[k] for r in rs])), 5) for k in _KEYS}
                for name, rs in (("marops", mine), ("best rule", best))
            },
        }
        self.evals.append(ev)
        if self.best is None or cost < self.best["cost"]:
            self.best = {"episode": self.episode, "cost": cost, "weight": list(w)}
        return ev

    # -- the run -----------------------------------------------------------------------
    def run(self, resume: bool) -> None:
        resumed = resume and self.load_checkpoint()
        t = self.tcfg
        self.emit(self.td.start_event(self.episode, resumed))
        per_generation = t.es_days * (2 * t.es_pairs + 1)
        with LocalPool(LandingWork(self.td.ctx), t.workers) as workers:
            if not self.evals:
                self._emit_eval(workers)
            while self.episode + per_generation <= t.episodes or self.generation == 0:
                before = self.episode
                stats = self._timed(self._generation, workers)
                self.emit({"kind": "update", **stats})
                if self.episode // t.eval_every > before // t.eval_every:
                    self._emit_eval(workers)
                if self.episode // t.checkpoint_every > before // t.checkpoint_every:
                    self.save_checkpoint()
            if self.evals and self.evals[-1]["episode"] != self.episode:
                self._emit_eval(workers)
        self.save_checkpoint()

    def _emit_eval(self, workers: LocalPool) -> None:
        ev = self._timed(self.evaluate, workers)
        if ev is not None:
            self.emit({"kind": "eval", **ev})

    def _timed(self, fn: Callable[[LocalPool], Any], workers: LocalPool) -> Any:
        t0 = time.perf_counter()
        try:
            return fn(workers)
        finally:
            self.elapsed_s += time.perf_counter() - t0

    def export(self, command: str | None, data_origin: str | None = None) -> dict[str, Any]:
        """Write the weights file and its sidecar (docs/method.md §6.1)."""
        t, cfg = self.tcfg, self.td.ctx.scenarios[0].cfg
        chosen = self.evals[-1] if self.evals else None
        weight = self.weight
        if t.keep_best and self.best is not None:
            weight = np.array(self.best["weight"])
            chosen = next(e for e in self.evals if e["episode"] == self.best["episode"])
        side = {
            "format": FEATURE_SETS[t.landing_features].format,
            "method": "marops",
            "operating_model": self.model,
            "features": list(FEATURE_SETS[t.landing_features].names),
            "weight": [round(float(x), 6) for x in weight],
            "seed": t.seed,
            "episodes": self.episode,
            "generations": self.generation,
            "command": command,
            "training_time_s": round(self.elapsed_s, 1),
            "marops": __version__,
            "data": {**self.td.files[0], "origin": data_origin},
            "scenarios": [
                {
                    "name": s.name,
                    "n_depots": len(s.depots),
                    "drones": s.cfg.sim.drones,
                    "spares": s.cfg.ops.batteries_per_depot,
                    "chargers": s.cfg.ops.chargers_per_depot,
                    "charge_power_w": s.cfg.ops.charge_power_w,
                }
                for s in self.td.ctx.scenarios
            ],
            "files": self.td.files,
            "reward": f"cost = J / J of the day's best rule ({', '.join(self.rules)}) + "
            f"es_energy_weight * max(0, energy per {t.es_energy_basis} / its - 1 - "
            "es_energy_slack) + "
            "es_loss_weight * max(0, J / its J - 1), mean over days (docs/method.md §6.1)",
            "train_config": t.model_dump(mode="json"),
            "planner_config": cfg.model_dump(mode="json"),
            "heldout": chosen,
            "exported_episode": chosen["episode"] if chosen else self.episode,
            "evaluations": [{"episode": e["episode"], "cost": e["cost"]} for e in self.evals],
            "learning_curve": self.history,
        }
        return write_landing_actor(weight, self.out, side)


def day_cost(
    row: dict[str, float],
    ref: dict[str, float],
    weight: float,
    slack: float = 0.0,
    loss_weight: float = 0.0,
    *,
    per_parcel: bool = False,
) -> float:
    """A day's cost of a replay ``row`` against the day's best rule ``ref`` (its ``j``,
    ``energy`` and delivered ``share``): J / the best rule's J, plus ``weight`` × the share
    of energy per drone (``per_parcel``: per delivered parcel) above the best rule's beyond
    ``slack`` (a hinge: up to ``slack`` more energy is free, every share beyond costs
    ``weight``), plus ``loss_weight`` × the share of J above the best rule's (a day lost
    costs more than a day won gains)."""
    ratio = row["mean_energy_kj"] / max(ref["energy"], 1e-9)
    if per_parcel:  # the same day and fleet: energy per parcel ∝ energy per drone / share
        ratio *= max(ref["share"], 1e-9) / max(row["delivered_share"], 1e-9)
    excess = ratio - 1.0 - slack
    rel = row["objective_j_mj"] / max(ref["j"], 1e-9)
    return rel + weight * max(0.0, excess) + loss_weight * max(0.0, rel - 1.0)


def _reference(best: dict[str, Any]) -> dict[str, float]:
    """What :func:`day_cost` compares a replay with: the best rule's J, energy per drone
    and delivered share."""
    return {
        "j": best["objective_j_mj"],
        "energy": best["mean_energy_kj"],
        "share": best["delivered_share"],
    }


def _key(d: Day) -> str:
    return f"{d[0]}/{d[1]}/{d[2]}"


def landing_weights_bytes(weight: np.ndarray) -> bytes:
    """The weights as a safetensors file: one float32 tensor ``weight``."""
    from safetensors.numpy import save

    return save({"weight": np.ascontiguousarray(weight, dtype=np.float32)})


def write_landing_actor(weight: np.ndarray, path: str | Path, sidecar: dict[str, Any]) -> dict:
    """Write ``NAME.safetensors`` and its ``NAME.json`` sidecar together, atomically
    (``path`` may name either); returns the sidecar written."""
    base = Path(path).with_suffix("")
    with output_set() as files:
        files.write_bytes(base.with_suffix(".safetensors"), landing_weights_bytes(weight))
        files.write_json(base.with_suffix(".json"), sidecar)
    return sidecar
