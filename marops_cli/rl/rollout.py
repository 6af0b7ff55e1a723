"""Rollouts and evaluations of one day, deterministic for their inputs: the worker
pool runs them as training's tasks (marops_cli/rl/tasks.py), in whichever process.

Everything that decides an outcome is an argument (actor weights, day, seed), so one
worker or many, the same run gives the same numbers.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch.distributions import Categorical

from ..config import PlannerConfig
from ..data.table import DayRequests
from ..policies.direct import SlotSelector
from ..policies.observation import (
    ObsVersion,
    best_value_action,
)
from ..policies.recurrent import RecurrentPolicy
from ..segment.depots import Depots
from ..sim.metrics import day_metrics, metric_names
from ..sim.replay import fly_day
from ..sim.state import default_fleet
from ..sim.step import WindowStep
from .config import TrainConfig
from .env import DeliveryEnv
from .networks import Actor
from .ppo import MASKED_LOGIT

EVAL_KEYS = metric_names(
    "mean_energy_kj",
    "avg_delay_h",
    "delivered",
    "undelivered",
    "delay_unfairness",
    "avg_early_h",
)


def derive_seed(*parts: int) -> int:
    """A 32-bit seed from a tuple of integers (e.g. run seed, stream, episode)."""
    return int(np.random.SeedSequence([int(p) for p in parts]).generate_state(1)[0])


@dataclass
class Episode:
    """One day of one sampled rollout: arrays are ``(T, U, ...)``."""

    obs: np.ndarray
    actions: np.ndarray
    logp: np.ndarray
    mask: np.ndarray
    rewards: np.ndarray
    teacher: np.ndarray
    """``(T, U)`` the target of the imitation term on each observation
    (``TrainConfig.bc_teacher``: the free landing, or the one-window best response);
    -1 where there is none (version 2)."""
    energy_kj: float
    delay_h: float


@dataclass
class TrainScenario:
    """One city (file) with one segmentation and fleet size: depots, settings, days."""

    name: str
    depots: Depots
    cfg: PlannerConfig
    train_days: list[DayRequests]
    eval_days: list[DayRequests]


@dataclass
class WorkerContext:
    """What every worker holds: the scenarios and their days, sent once at start-up."""

    scenarios: list[TrainScenario]
    tcfg: TrainConfig


def make_actor(env: DeliveryEnv, tcfg: TrainConfig) -> Actor:
    return Actor(env.obs_dim, env.n_logits, tcfg.hidden_size)


def run_episode(
    env: DeliveryEnv, actor: Actor, day: DayRequests, seed: int, alpha: float | None = None
) -> Episode:
    """Sample the actor's actions for a whole day (Alg. 3, inner loop), at trade-off
    ``alpha`` (default: the scenario's)."""
    gen = torch.Generator().manual_seed(seed)
    env.reset(day, alpha=alpha)
    h = torch.zeros(env.n_drones, actor.hidden_size)
    rec: dict[str, list[np.ndarray]] = {
        k: [] for k in ("obs", "actions", "logp", "mask", "rewards", "teacher")
    }
    energy = delay = 0.0
    while not env.done:
        mask = env.action_mask()
        logp = np.zeros(env.n_drones, dtype=np.float32)

        def choose(
            drones: np.ndarray, obs: np.ndarray, mask: np.ndarray = mask, logp: np.ndarray = logp
        ) -> np.ndarray:
            idx = torch.from_numpy(drones)
            with torch.no_grad():
                logits, h[idx] = actor(torch.from_numpy(obs), h[idx])
                m = torch.from_numpy(mask[drones])
                dist = Categorical(logits=logits.masked_fill(~m, MASKED_LOGIT))
                a = torch.multinomial(dist.probs, 1, generator=gen).squeeze(-1)
                logp[drones] = dist.log_prob(a).numpy()
            return a.numpy()

        obs, actions = env.observe(choose)
        rec["obs"].append(obs)
        rec["mask"].append(mask)
        rec["actions"].append(actions)
        rec["logp"].append(logp)
        rec["teacher"].append(_teacher(env, obs, mask))
        r, info = env.step(actions)
        rec["rewards"].append(r)
        energy += float(info["energy_kj"].sum())
        delay += float(info["late_h"])
    return Episode(
        obs=np.stack(rec["obs"]).astype(np.float32),
        actions=np.stack(rec["actions"]).astype(np.int64),
        logp=np.stack(rec["logp"]).astype(np.float32),
        mask=np.stack(rec["mask"]),
        rewards=np.stack(rec["rewards"]).astype(np.float64),
        teacher=np.stack(rec["teacher"]).astype(np.int64),
        energy_kj=energy,
        delay_h=delay,
    )


def _teacher(env: DeliveryEnv, obs: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Imitation targets of one window (``TrainConfig.bc_teacher``); -1: none (version 2)."""
    if env.obs_version < ObsVersion.SEQUENTIAL:
        return np.full(env.n_drones, -1, dtype=np.int64)
    if env.tcfg.bc_teacher == "free" and env.obs_version >= ObsVersion.ANTICIPATION:
        return np.full(env.n_drones, env.n_dest, dtype=np.int64)  # the last choice: free
    return best_value_action(obs, mask, env.obs_version)


def actor_policy(
    actor: Actor, n_slots: int = 1, name: str = "actor", version: int = ObsVersion.ANTICIPATION
) -> RecurrentPolicy:
    """An in-memory actor as a policy, flown by the same drive as the exported file
    (:class:`~marops_cli.policies.recurrent.RecurrentPolicy`), so evaluation replays days
    exactly as ``replay-day`` does."""
    selector = SlotSelector(n_slots) if n_slots > 1 else None
    free = 1 if version >= ObsVersion.ANTICIPATION else 0  # the free landing, last
    n_actions = actor.head.out_features // n_slots - free
    return RecurrentPolicy(
        actor,
        n_actions,
        actor.hidden_size,
        version,
        n_slots=n_slots,
        selector=selector,
        name=name,
    )


def evaluate_day(
    policy: Any, day: DayRequests, depots: Depots, cfg: PlannerConfig, method: str
) -> dict[str, Any]:
    """Replay ``day`` with ``policy`` and keep the metrics training reports."""
    how = WindowStep.of(policy, cfg)
    fleet = default_fleet(depots, cfg.sim.drones)
    res = fly_day(day, depots, fleet, policy, cfg, method=method, how=how)
    m = day_metrics(res, how.model)
    return {"day": m["day"], "method": method, **{k: m[k] for k in EVAL_KEYS}}
