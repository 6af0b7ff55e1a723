"""Rollouts and evaluations, in worker processes, deterministic whatever the scheduling.

Every task carries everything that decides its outcome (actor weights, day,
seed), each worker runs torch single-threaded, and results come back in task
order: one worker or many, the same run gives the same numbers.
"""

from __future__ import annotations

import multiprocessing as mp
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import torch
from torch.distributions import Categorical

from ..config import PlanConfig, PlannerConfig
from ..data.table import DayRequests
from ..energy import EnergyModel
from ..policies.base import PolicyBase, WindowView
from ..policies.direct import SlotSelector
from ..policies.observation import best_value_action, observe_and_choose
from ..policies.registry import make_policy
from ..segment.depots import Depots
from ..sim.metrics import day_metrics
from ..sim.replay import replay_day
from ..sim.state import default_fleet
from .config import TrainConfig
from .env import DeliveryEnv
from .networks import Actor
from .ppo import MASKED_LOGIT

EVAL_KEYS = (
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
    """``(T, U)`` the one-window best response (``myopic``) on each observation (version
    3), the target of the imitation term; -1 where there is none (version 2)."""
    energy_kj: float
    delay_h: float


@dataclass
class WorkerContext:
    """What every worker holds: the scenario and the days, sent once at start-up."""

    depots: Depots
    cfg: PlannerConfig
    tcfg: TrainConfig
    train_days: list[DayRequests]
    eval_days: list[DayRequests]


def make_actor(env: DeliveryEnv, tcfg: TrainConfig) -> Actor:
    return Actor(env.obs_dim, env.n_logits, tcfg.hidden_size)


def run_episode(env: DeliveryEnv, actor: Actor, day: DayRequests, seed: int) -> Episode:
    """Sample the actor's actions for a whole day (Alg. 3, inner loop)."""
    gen = torch.Generator().manual_seed(seed)
    env.reset(day)
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
        rec["teacher"].append(
            best_value_action(obs, mask)
            if env.obs_version == 3
            else np.full(env.n_drones, -1, dtype=np.int64)
        )
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


class ActorPolicy(PolicyBase):
    """An in-memory actor as a :class:`~marops_cli.policies.base.Policy` (arg-max actions),
    so evaluation replays days exactly as ``replay-day`` does with the exported file."""

    scope: Literal["range", "global"] = "range"

    def __init__(
        self,
        actor: Actor,
        n_slots: int = 1,
        name: str = "actor",
        version: int = 3,
    ) -> None:
        self.actor = actor
        self.version = version
        self.model: EnergyModel | None = None
        self.plan: PlanConfig | None = None
        self.n_slots = n_slots
        self.name = name
        self.slots = SlotSelector(n_slots) if n_slots > 1 else None
        self.selector = self.slots
        self.planner = "subsets" if n_slots > 1 else None  # MAPPO ranks the paper's plans
        self._h: torch.Tensor | None = None

    def configure(self, cfg: PlannerConfig) -> None:
        """Price version-3 observations with the run's planner settings (``start_day``)."""
        self.model, self.plan = EnergyModel(cfg.energy), cfg.plan

    def reset(self, seed: int) -> None:
        self._h = None

    def act(self, view: WindowView) -> np.ndarray:
        if self._h is None:
            self._h = torch.zeros(view.n_drones, self.actor.hidden_size)
        h = self._h
        mask = np.repeat(view.action_mask(), self.n_slots, axis=1)

        def choose(drones: np.ndarray, obs: np.ndarray) -> np.ndarray:
            idx = torch.from_numpy(drones)
            with torch.no_grad():
                logits, h[idx] = self.actor(torch.from_numpy(obs), h[idx])
            m = torch.from_numpy(mask[drones])
            return torch.argmax(logits.masked_fill(~m, MASKED_LOGIT), dim=1).numpy()

        _, joint = observe_and_choose(view, choose, self.version, model=self.model, plan=self.plan)
        if self.slots is not None:
            self.slots.slots = joint % self.n_slots
        return (joint // self.n_slots).astype(np.int64)


def evaluate_day(
    policy: Any, day: DayRequests, depots: Depots, cfg: PlannerConfig, method: str
) -> dict[str, Any]:
    """Replay ``day`` with ``policy`` and keep the metrics training reports."""
    model = EnergyModel(cfg.energy)
    fleet = default_fleet(depots, cfg.sim.drones)
    res = replay_day(
        day,
        depots,
        fleet,
        policy,
        cfg,
        method=method,
        model=model,
        selector=policy.selector,
    )
    m = day_metrics(res, model)
    return {"day": m["day"], "method": method, **{k: m[k] for k in EVAL_KEYS}}


_CTX: WorkerContext | None = None
_ENV: DeliveryEnv | None = None


def _init(ctx: WorkerContext) -> None:
    global _CTX, _ENV
    torch.set_num_threads(1)  # one process per core; threads would only add noise
    torch.use_deterministic_algorithms(True)
    _CTX = ctx
    _ENV = DeliveryEnv(ctx.depots, ctx.cfg, ctx.tcfg)


def _work(task: tuple[Any, ...]) -> Any:
    assert _CTX is not None and _ENV is not None
    kind = task[0]
    if kind == "baseline":
        _, name, i = task
        pol = make_policy(name, _CTX.cfg.sim.seed)
        return evaluate_day(pol, _CTX.eval_days[i], _CTX.depots, _CTX.cfg, name)
    actor = make_actor(_ENV, _CTX.tcfg)
    actor.load_state_dict(task[1])
    actor.eval()
    if kind == "train":
        _, _, i, seed = task
        return run_episode(_ENV, actor, _CTX.train_days[i], seed)
    _, _, i = task
    pol = ActorPolicy(actor, _ENV.n_slots, name=_CTX.tcfg.method, version=_ENV.obs_version)
    return evaluate_day(pol, _CTX.eval_days[i], _CTX.depots, _CTX.cfg, _CTX.tcfg.method)


class Workers:
    """A pool of rollout processes ('spawn': safe with torch), or the caller itself
    when ``n == 1``. Use as a context manager."""

    def __init__(self, ctx: WorkerContext, n: int) -> None:
        self.n = n
        self._pool = None
        if n > 1:
            self._pool = mp.get_context("spawn").Pool(n, initializer=_init, initargs=(ctx,))
        else:
            _init(ctx)

    def map(self, tasks: list[tuple[Any, ...]]) -> list[Any]:
        """Run ``tasks`` and return their results in task order."""
        if self._pool is None:
            return [_work(t) for t in tasks]
        return self._pool.map(_work, tasks, chunksize=1)

    def close(self) -> None:
        if self._pool is not None:
            self._pool.close()
            self._pool.join()
            self._pool = None

    def __enter__(self) -> Workers:
        return self

    def __exit__(self, *exc: object) -> None:
        if self._pool is not None and exc[0] is not None:
            self._pool.terminate()
        self.close()
