"""MAPPO training of the flight-range actor (paper Alg. 3), resumable and deterministic.

Episodes are training days; each PPO update gathers ``episodes_per_update`` of
them from the worker pool. Every random stream derives from ``(seed, stream,
index)``, so a run resumed from its checkpoint ends with the same weights as one
that never stopped, whatever the number of workers.
"""

from __future__ import annotations

import functools
import pickle
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar, Literal

import numpy as np
import torch

from .. import __version__
from ..config import clipped
from ..errors import InputError
from ..io.atomic import output_set
from ..policies.landing import operating_model
from ..policies.observation import ObsVersion
from ..workers import LocalPool, single_threaded
from .data import (
    TrainData,
    edited_checkpoint,
    fingerprint,
    load_training_data,
    other_algorithm,
    other_run,
    oversized_checkpoint,
    split_days,
)
from .env import DeliveryEnv
from .evaluate import summarise
from .export import Written, write_actor
from .networks import Actor, Critic
from .ppo import make_batch, ppo_update
from .rollout import Episode, derive_seed
from .tasks import ActorDay, BaselineDay, RolloutWork, TrainEpisode

__all__ = ["Trainer", "load_training_data", "split_days", "train_actor"]

BASELINES = ("random", "greedy", "myopic", "global")  # on held-out days (ops-random, …, ops-global)
_STREAM_DAYS, _STREAM_EPISODE, _STREAM_UPDATE, _STREAM_SCENARIO, _STREAM_ALPHA = 1, 2, 3, 4, 5
Event = dict[str, Any]
CKPT_FORMAT = "marops-train-ckpt/1"
_KIND = "a training checkpoint"  # as the refusals name it


def _stack(eps: list[Episode], name: str) -> np.ndarray:
    """``(T, E, U, ...)``: episodes side by side, windows first."""
    return np.stack([getattr(ep, name) for ep in eps], axis=1)


class Trainer:
    """Actor, critic, optimiser and progress of one run; :meth:`run` trains to the end."""

    def __init__(self, td: TrainData, out: Path, on_event: Callable[[Event], None] | None = None):
        self.td, self.tcfg, self.out = td, td.ctx.tcfg, Path(out)
        self.ckpt = self.out.with_suffix(".ckpt")
        self.emit = on_event or (lambda e: None)
        torch.manual_seed(self.tcfg.seed)
        scns = td.ctx.scenarios
        if len({s.depots.n_actions for s in scns}) > 1:
            # A city with fewer depots than segment.n_actions gives each drone fewer
            # destinations, and one actor has one number of choices.
            counts = sorted({(len(s.depots), s.depots.n_actions) for s in scns})
            said = ", ".join(f"{k} with {n} depots" for n, k in counts)
            raise InputError(
                "every training scenario needs the same number of destinations per drone "
                f"(segment.n_actions), and these have {said}: train on at least "
                f"{max(k for _, k in counts)} depots in every city (--n-depots)"
            )
        env = DeliveryEnv(scns[0].depots, scns[0].cfg, self.tcfg)
        self.n_actions, self.n_slots = env.n_dest, env.n_slots
        self.obs_version = env.obs_version
        self.actor = Actor(env.obs_dim, env.n_logits, self.tcfg.hidden_size)
        self.critic = Critic(env.obs_dim, self.tcfg.critic_hidden)
        params = [*self.actor.parameters(), *self.critic.parameters()]
        self.optimizer = torch.optim.Adam(params, lr=self.tcfg.lr, eps=1e-5)
        self.episode = self.update = 0
        self.elapsed_s = 0.0
        self.history: list[dict[str, float]] = []
        self.evals: list[dict[str, Any]] = []
        self.baselines: list[dict[str, Any]] = []
        self.best: dict[str, Any] | None = None  # {"episode", "daily_combined_cost", "actor"}

    # -- checkpoints -----------------------------------------------------------------
    def save_checkpoint(self) -> None:
        """Write ``NAME.ckpt`` atomically (temporary file, then rename)."""
        state = {
            "format": CKPT_FORMAT,
            "fingerprint": fingerprint(self.td),
            "episode": self.episode,
            "update": self.update,
            "elapsed_s": self.elapsed_s,
            "actor": self.actor.state_dict(),
            "critic": self.critic.state_dict(),
            "optimizer": self.optimizer.state_dict(),
            "history": self.history,
            "evals": self.evals,
            "baselines": self.baselines,
            "best": self.best,
        }
        with output_set() as files:  # complete or absent (docs/outputs.md)
            files.write_with(self.ckpt, lambda tmp: torch.save(state, tmp))

    def load_checkpoint(self) -> bool:
        """Resume from ``NAME.ckpt`` when there is one; refuse one made differently."""
        if not self.ckpt.is_file():
            return False
        wrong = other_algorithm(self.ckpt, "ppo") or oversized_checkpoint(self.ckpt)
        if wrong is not None:
            raise wrong
        try:
            state = torch.load(self.ckpt, map_location="cpu", weights_only=True)
        except pickle.UnpicklingError as exc:  # what torch refused to load, not its advice
            lines = [x.strip() for x in str(exc).splitlines() if x.strip()]
            why = next((x for x in lines if x.startswith(("Trying", "Unsupported"))), None)
            raise InputError(
                "not a training checkpoint: it holds objects other than tensors and plain "
                f"data, which marops never loads ({clipped(why or type(exc).__name__, 120)}); "
                "pass --no-resume",
                file=self.ckpt,
            ) from None
        except Exception as exc:  # a torn or foreign file: say which, never guess
            why = (str(exc).strip().splitlines() or [type(exc).__name__])[0]  # torch's is long
            raise InputError(
                f"unreadable checkpoint ({why}); pass --no-resume", file=self.ckpt
            ) from exc
        if not isinstance(state, dict) or state.get("format") != CKPT_FORMAT:
            raise InputError(
                f"not a training checkpoint (format {CKPT_FORMAT}); pass --no-resume",
                file=self.ckpt,
            )
        mismatch = other_run(self.ckpt, state.get("fingerprint"), fingerprint(self.td))
        if mismatch is not None:
            raise mismatch
        try:
            self._restore(state)
        except (KeyError, TypeError, ValueError, AttributeError, RuntimeError, OverflowError) as e:
            raise edited_checkpoint(self.ckpt, _KIND, e) from None
        if self.episode > self.tcfg.episodes:  # it would export that actor as this run's
            raise InputError(
                f"checkpoint is at episode {self.episode}, past --episodes "
                f"{self.tcfg.episodes}: pass --episodes {self.episode} or more to go on from "
                "it, or --no-resume to start over",
                file=self.ckpt,
            )
        return True

    def _restore(self, state: dict[str, Any]) -> None:
        """The networks, optimiser and progress of a checkpoint's ``state``, before any
        training. Its plain data is :func:`_checkpoint_model`'s, refused naming the key
        (``history[3].reward``); then what its parts say of each other (best among the
        evaluations, its actor this run's network) and the tensors: raises KeyError,
        TypeError, ValueError or RuntimeError on networks of another shape or weights that
        are not finite numbers. What the run reads back later (the best actor, the
        evaluations, the learning curve) is checked too."""
        from pydantic import ValidationError

        from ..data.filemodel import error_text

        _name_daily_cost(state)
        model = _checkpoint_model()
        try:
            ckpt = model.model_validate(state)
        except ValidationError as exc:
            key, msg = error_text(exc, model)
            raise edited_checkpoint(self.ckpt, _KIND, f"{key}: {msg}" if key else msg) from None
        best = ckpt.best
        if best is not None:
            if best.episode not in [e.episode for e in ckpt.evals]:
                raise ValueError("best must be one of the evaluations")
            if _shapes(best.actor) != _shapes(self.actor.state_dict()):
                raise ValueError("best's actor is not this run's network")
            _all_finite("best actor", best.actor)
        self.actor.load_state_dict(state["actor"])
        self.critic.load_state_dict(state["critic"])
        self.optimizer.load_state_dict(state["optimizer"])
        _all_finite("actor", state["actor"])
        _all_finite("critic", state["critic"])
        _all_finite("optimizer", state["optimizer"]["state"])
        self.episode, self.update, self.elapsed_s = ckpt.episode, ckpt.update, ckpt.elapsed_s
        # As written (the model checked them): the run appends to them and writes them back.
        self.history, self.evals, self.baselines = (
            state[k] for k in ("history", "evals", "baselines")
        )
        self.best = state["best"]

    # -- one update --------------------------------------------------------------------
    def _scenario_of(self, update: int) -> int:
        """Scenarios in a fresh shuffled order per pass over them; one per update (its
        episodes share a fleet size, so they stack into one batch)."""
        n = len(self.td.ctx.scenarios)
        perm = np.random.default_rng(
            derive_seed(self.tcfg.seed, _STREAM_SCENARIO, update // n)
        ).permutation(n)
        return int(perm[update % n])

    def _day_of(self, scenario: int, episode: int) -> int:
        """Training days in a fresh shuffled order per pass (epoch) over them."""
        n = len(self.td.ctx.scenarios[scenario].train_days)
        perm = np.random.default_rng(
            derive_seed(self.tcfg.seed, _STREAM_DAYS, episode // n)
        ).permutation(n)
        return int(perm[episode % n])

    def _alpha_of(self, episode: int) -> float | None:
        """The episode's trade-off α: drawn from ``alpha_range`` (actors that observe α),
        else None (the config's)."""
        lo_hi = self.tcfg.alpha_range
        if lo_hi is None or self.obs_version < ObsVersion.ANTICIPATION:
            return None
        rng = np.random.default_rng(derive_seed(self.tcfg.seed, _STREAM_ALPHA, episode))
        return round(float(rng.uniform(*lo_hi)), 3)

    def _update(self, workers: LocalPool) -> dict[str, float]:
        n = min(self.tcfg.episodes_per_update, self.tcfg.episodes - self.episode)
        state = {k: v.clone() for k, v in self.actor.state_dict().items()}
        j = self._scenario_of(self.update)
        tasks = [
            TrainEpisode(
                k,
                state,
                j,
                self._day_of(j, e),
                derive_seed(self.tcfg.seed, _STREAM_EPISODE, e),
                self._alpha_of(e),
            )
            for k, e in enumerate(range(self.episode, self.episode + n))
        ]
        eps: list[Episode] = workers.results(tasks)
        obs, actions, logp, mask, rewards = (
            _stack(eps, k) for k in ("obs", "actions", "logp", "mask", "rewards")
        )
        teacher = _stack(eps, "teacher")
        batch = make_batch(obs, actions, logp, mask, rewards, self.critic, self.tcfg, teacher)
        if self.tcfg.anneal_lr:
            frac = 1.0 - self.episode / self.tcfg.episodes
            for g in self.optimizer.param_groups:
                g["lr"] = self.tcfg.lr * max(frac, 0.02)
        gen = torch.Generator().manual_seed(
            derive_seed(self.tcfg.seed, _STREAM_UPDATE, self.update)
        )
        stats = ppo_update(
            self.actor, self.critic, self.optimizer, batch, self.tcfg, gen, self.bc_weight()
        )
        self.episode += n
        self.update += 1
        stats.update(
            episode=self.episode,
            reward=float(np.mean([ep.rewards.sum(axis=0).mean() for ep in eps])),
            delay_h=float(np.mean([ep.delay_h for ep in eps])),
            energy_kj=float(np.mean([ep.energy_kj for ep in eps])),
        )
        self.history.append(stats)
        return stats

    def bc_weight(self) -> float:
        """Weight of the imitation term now: ``bc_coef`` falling linearly to 0 at
        ``bc_anneal`` of the run (MAPPO has no target: 0)."""
        t = self.tcfg
        span = t.bc_anneal * t.episodes
        if self.obs_version < ObsVersion.SEQUENTIAL or span <= 0:
            return 0.0
        return t.bc_coef * max(0.0, 1.0 - self.episode / span)

    def evaluate(self, workers: LocalPool) -> dict[str, Any] | None:
        """Arg-max actor on the held-out days, with the baselines' numbers beside it."""
        cap = self.tcfg.eval_days_per_scenario
        days = [
            (j, i)
            for j, s in enumerate(self.td.ctx.scenarios)
            for i in range(len(s.eval_days) if cap == 0 else min(cap, len(s.eval_days)))
        ]
        if not days:
            return None
        if not self.baselines:
            runs = [(b, j, i) for b in BASELINES for j, i in days]
            tasks = [BaselineDay(k, b, j, i) for k, (b, j, i) in enumerate(runs)]
            self.baselines = workers.results(tasks)
        state = {k: v.clone() for k, v in self.actor.state_dict().items()}
        rows = workers.results([ActorDay(k, state, j, i) for k, (j, i) in enumerate(days)])
        ev = {"episode": self.episode, **summarise(rows, self.baselines)}
        self.evals.append(ev)
        cc = float(ev["methods"][self.tcfg.method]["daily_combined_cost"])
        if self.best is None or cc < self.best["daily_combined_cost"]:
            self.best = {"episode": self.episode, "daily_combined_cost": cc, "actor": state}
        return ev

    def run(self, resume: bool) -> None:
        resumed = resume and self.load_checkpoint()
        t = self.tcfg
        self.emit(self.td.start_event(self.episode, resumed))
        with LocalPool(RolloutWork(self.td.ctx), t.workers) as workers:
            while self.episode < t.episodes:
                t0 = time.perf_counter()
                before = self.episode
                stats = self._update(workers)
                self.elapsed_s += time.perf_counter() - t0
                self.emit({"kind": "update", **stats})
                done = self.episode >= t.episodes
                if done or self.episode // t.eval_every > before // t.eval_every:
                    t0 = time.perf_counter()
                    ev = self.evaluate(workers)
                    self.elapsed_s += time.perf_counter() - t0
                    if ev is not None:
                        self.emit({"kind": "eval", **ev})
                if done or self.episode // t.checkpoint_every > before // t.checkpoint_every:
                    self.save_checkpoint()
            if not self.evals or self.evals[-1]["episode"] != self.episode:
                ev = self.evaluate(workers)
                if ev is not None:
                    self.emit({"kind": "eval", **ev})

    def export(self, command: str | None, data_origin: str | None = None) -> Written:
        """Write the TorchScript actor and its sidecar (docs/method.md §6)."""
        t, cfg = self.tcfg, self.td.ctx.scenarios[0].cfg
        chosen = self.evals[-1] if self.evals else None
        if t.keep_best and self.best is not None:
            self.actor.load_state_dict(self.best["actor"])
            chosen = next(e for e in self.evals if e["episode"] == self.best["episode"])
        side: dict[str, Any] = {
            "method": t.method,
            "operating_model": operating_model(cfg.ops),
            "obs_version": int(self.obs_version),
            "n_actions": self.n_actions,
            "alpha": cfg.plan.alpha,
            "seed": t.seed,
            "episodes": self.episode,
            "command": command,
            "training_time_s": round(self.elapsed_s, 1),
            "marops": __version__,
            "data": {
                **self.td.files[0],  # file, sha256, train_days, heldout_days
                "origin": data_origin,
            },
            "scenarios": [
                {"name": s.name, "n_depots": len(s.depots), "drones": s.cfg.sim.drones}
                for s in self.td.ctx.scenarios
            ],
            "files": self.td.files,
            "reward": "eq. (10): -(1-alpha)*s(D_u/delay_scale_h) - alpha*s(E_u/energy_scale_kj), "
            "s(x) = 2*sigmoid(ln3*x) - 1 (marops_cli/rl/env.py)",
            "train_config": t.model_dump(mode="json"),
            "planner_config": cfg.model_dump(mode="json"),
            "heldout": chosen,
            "exported_episode": chosen["episode"] if chosen else self.episode,
            "evaluations": [
                {
                    "episode": e["episode"],
                    **{m: v["daily_combined_cost"] for m, v in e["methods"].items()},
                }
                for e in self.evals
            ],
            "learning_curve": [
                {k: round(float(h[k]), 4) for k in ("episode", "reward", "delay_h", "energy_kj")}
                for h in self.history
            ],
        }
        if t.method == "mappo":
            side["plan_slots"] = t.plan_slots
        return write_actor(self.actor, self.out, side)


@functools.cache
def _checkpoint_model() -> type[Any]:
    """The plain data of a training checkpoint as :meth:`Trainer.save_checkpoint` writes
    it (docs/decisions.md, "Files read"): its counts, learning curve, evaluations,
    baselines and best evaluation. The tensors' parts (the networks, the optimiser, the
    best actor) are tables here, and checked by the networks that load them."""
    from pydantic import ConfigDict, Field

    from ..data.filemodel import FileModel, Whole

    tensors = "a state dict of tensors"

    class Numbers(FileModel):
        """A table of numbers: the keys named, and others of any name (kept as written)."""

        model_config = ConfigDict(extra="allow")
        __pydantic_extra__: dict[str, float] = Field(init=False)

    class Step(Numbers):  # the update's loss terms beside the learning curve's numbers
        noun: ClassVar[str] = "history entry"
        shape: ClassVar[str] = "a history entry {episode, reward, delay_h, energy_kj, …}"
        episode: float
        reward: float
        delay_h: float
        energy_kj: float

    class Costs(Numbers):  # a method's held-out metrics
        noun: ClassVar[str] = "method's costs"
        shape: ClassVar[str] = "a method's costs {daily_combined_cost, …}"
        daily_combined_cost: float

    class Baseline(Numbers):  # a baseline's held-out day
        noun: ClassVar[str] = "baseline day"
        shape: ClassVar[str] = "a baseline day {day, method, mean_energy_kj, avg_delay_h, …}"
        day: str
        method: str
        mean_energy_kj: float
        avg_delay_h: float

    class Evaluation(FileModel):
        noun: ClassVar[str] = "evaluation"
        episode: Whole = Field(ge=0)
        days: list[str]
        methods: dict[str, Costs]

    class Best(FileModel):
        noun: ClassVar[str] = "best evaluation"
        shape: ClassVar[str] = "the best evaluation {episode, daily_combined_cost, actor}"
        episode: Whole = Field(ge=0)
        daily_combined_cost: float
        actor: dict[str, Any] = Field(description=tensors)

    class Checkpoint(FileModel):
        noun: ClassVar[str] = "training checkpoint"
        format: Literal["marops-train-ckpt/1"]
        fingerprint: Any
        episode: Whole = Field(ge=0)
        update: Whole = Field(ge=0)
        elapsed_s: float = Field(ge=0)
        actor: dict[str, Any] = Field(description=tensors)
        critic: dict[str, Any] = Field(description=tensors)
        optimizer: dict[str, Any] = Field(description="an optimiser's state dict")
        history: list[Step]
        evals: list[Evaluation]
        baselines: list[Baseline]
        best: Best | None

    return Checkpoint


def _shapes(state: Any) -> dict[str, tuple[Any, ...]] | None:
    """Each tensor's name, shape and dtype of the state dict ``state`` (None: no state
    dict of tensors)."""
    if not isinstance(state, dict) or not all(isinstance(v, torch.Tensor) for v in state.values()):
        return None
    return {k: (tuple(v.shape), v.dtype) for k, v in state.items()}


def _all_finite(what: str, tensors: Any) -> None:
    """Raise ValueError naming ``what`` when a tensor in ``tensors`` (a state dict, or
    the optimiser's state: dicts of them) holds NaN or infinity."""
    if isinstance(tensors, torch.Tensor):
        if tensors.is_floating_point() and not bool(torch.isfinite(tensors).all()):
            raise ValueError(f"{what} holds NaN or infinite numbers")
    elif isinstance(tensors, dict):
        for v in tensors.values():
            _all_finite(what, v)


def _name_daily_cost(state: dict[str, Any]) -> None:
    """Checkpoints written before the daily combined cost had its name call it
    ``combined_cost``: rename it in place, keeping the keys' order, where the checkpoint
    has the shape to hold it (the model refuses any other)."""

    def renamed(d: Any) -> Any:
        if not isinstance(d, dict):
            return d
        return {("daily_combined_cost" if k == "combined_cost" else k): v for k, v in d.items()}

    evals, best = state.get("evals"), state.get("best")
    for e in evals if isinstance(evals, list) else ():
        if isinstance(e, dict) and isinstance(e.get("methods"), dict):
            e["methods"] = {m: renamed(v) for m, v in e["methods"].items()}
    if isinstance(best, dict) and "combined_cost" in best:
        best["daily_combined_cost"] = best.pop("combined_cost")


def train_actor(
    td: TrainData,
    out: str | Path,
    *,
    resume: bool = True,
    command: str | None = None,
    data_origin: str | None = None,
    on_event: Callable[[Event], None] | None = None,
) -> Written:
    """Train on the scenarios of ``td`` (:func:`~.data.load_training_data`), resuming
    from ``out``'s ``.ckpt`` when ``resume`` says so; write ``out``, its ``.json``
    sidecar and ``.curve.png``; return the sidecar and whether this installation's
    record of trained actors notes the actor.

    ``command`` and ``data_origin`` (how the data was made) go into the sidecar as given.
    """
    # One deterministic thread, as in the workers, for the networks' initialisation (its
    # QR factorisation depends on the thread count) and every update, so the arithmetic
    # is the same whatever --workers says and whatever ran before in this process.
    if td.ctx.tcfg.algorithm == "es":  # the landing actor (docs/method.md §6.1)
        from .es import LandingTrainer

        landing = LandingTrainer(td, Path(out), on_event)
        landing.run(resume)
        return Written(landing.export(command, data_origin), recorded=True)
    with single_threaded(deterministic=True):
        trainer = Trainer(td, Path(out), on_event)
        trainer.run(resume)
        return trainer.export(command, data_origin)
