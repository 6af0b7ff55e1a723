"""Training's jobs for the worker pool (marops_cli/workers): an episode to sample, a
held-out day for the actor or for a baseline.

Every task carries everything that decides its outcome (actor weights, day, seed), each
worker runs torch single-threaded and deterministic, and results come back in task
order: one worker or many, the same run gives the same numbers.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import torch

from ..policies.registry import make_policy
from .env import DeliveryEnv
from .rollout import (
    Episode,
    TrainScenario,
    WorkerContext,
    actor_policy,
    evaluate_day,
    make_actor,
    run_episode,
)

Weights = dict[str, torch.Tensor]
"""An actor's state dict."""


@dataclass(frozen=True)
class TrainEpisode:
    """Sample the actor with ``weights`` on training day ``day`` of scenario
    ``scenario``, seeded by ``seed``, at trade-off ``alpha`` (None: the scenario's)."""

    index: int
    weights: Weights
    scenario: int
    day: int
    seed: int
    alpha: float | None


@dataclass(frozen=True)
class ActorDay:
    """Replay held-out day ``day`` of scenario ``scenario`` with the arg-max actor."""

    index: int
    weights: Weights
    scenario: int
    day: int


@dataclass(frozen=True)
class BaselineDay:
    """Replay held-out day ``day`` of scenario ``scenario`` with baseline ``policy``."""

    index: int
    policy: str
    scenario: int
    day: int


Task = TrainEpisode | ActorDay | BaselineDay


@dataclass
class RolloutWork:
    """Training's :class:`~marops_cli.workers.Work`: the scenarios and their days, sent to
    each worker once; a worker builds its environments from them."""

    ctx: WorkerContext
    _envs: list[DeliveryEnv] = field(default_factory=list, repr=False, compare=False)

    preload = ("torch", __name__)

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_envs": []}  # each process builds its own

    def setup(self) -> None:
        torch.use_deterministic_algorithms(True)
        self._envs = [DeliveryEnv(s.depots, s.cfg, self.ctx.tcfg) for s in self.ctx.scenarios]

    def refuse(self) -> str | None:
        return None

    def run(self, task: Task) -> Episode | dict[str, Any]:
        """An :class:`Episode` for a training episode, else the day's metrics row."""
        scn, env = self.ctx.scenarios[task.scenario], self._envs[task.scenario]
        if isinstance(task, BaselineDay):
            pol = make_policy(task.policy, scn.cfg.sim.seed)
            row = evaluate_day(pol, scn.eval_days[task.day], scn.depots, scn.cfg, task.policy)
            return self._day_key(scn, row)
        actor = make_actor(env, self.ctx.tcfg)
        actor.load_state_dict(task.weights)
        actor.eval()
        if isinstance(task, TrainEpisode):
            return run_episode(env, actor, scn.train_days[task.day], task.seed, task.alpha)
        method = self.ctx.tcfg.method
        pol = actor_policy(actor, env.n_slots, name=method, version=env.obs_version)
        row = evaluate_day(pol, scn.eval_days[task.day], scn.depots, scn.cfg, method)
        return self._day_key(scn, row)

    def _day_key(self, scn: TrainScenario, row: dict[str, Any]) -> dict[str, Any]:
        """A held-out row keyed by scenario and day when the run has several scenarios."""
        if len(self.ctx.scenarios) > 1:
            row["day"] = f"{scn.name}:{row['day']}"
        return row
