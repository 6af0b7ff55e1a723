"""PPO pieces in the open (cleanrl style): GAE, the clipped loss term by term, one update.

The paper's §IV-D equations, cited by their LaTeX labels (the paper numbers them
after the reward, the paper's eq. (10)): ``eq:advantage`` (here GAE, which is that
one-step advantage at λ = 0), ``eq:prob`` (the ratio), ``eq:clip_obj`` (the
clipped surrogate), ``eq:actor`` and ``eq:critic`` (the two losses).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch import nn
from torch.distributions import Categorical

from .config import TrainConfig
from .networks import Actor, Critic, fleet_input

MASKED_LOGIT = -1e9  # finite, so masked actions give p log p = 0 rather than NaN


def gae(
    rewards: np.ndarray,
    values: np.ndarray,
    gamma: float,
    lam: float,
    last_value: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Generalised advantage estimates and returns, both ``(T, ...)``.

    The episode ends after step T−1 (the day is over), so the value after it is
    ``last_value`` (0 by default). Returns are advantages + values: the critic's target.
    """
    adv = np.zeros_like(values, dtype=np.float64)
    next_value = np.zeros_like(values[0]) if last_value is None else last_value
    running = np.zeros_like(values[0], dtype=np.float64)
    for t in reversed(range(rewards.shape[0])):
        delta = rewards[t] + gamma * next_value - values[t]  # eq:advantage, the one-step TD error
        running = delta + gamma * lam * running
        adv[t] = running
        next_value = values[t]
    return adv, adv + values


def ppo_loss(
    new_logp: torch.Tensor,
    old_logp: torch.Tensor,
    advantages: torch.Tensor,
    new_values: torch.Tensor,
    returns: torch.Tensor,
    entropy: torch.Tensor,
    clip: float,
    vf_coef: float,
    ent_coef: float,
) -> dict[str, torch.Tensor]:
    """The PPO loss and its terms (to minimise)."""
    ratio = torch.exp(new_logp - old_logp)  # eq:prob
    # eq:clip_obj: the clipped surrogate, negated because we minimise.
    pg_unclipped = -advantages * ratio
    pg_clipped = -advantages * torch.clamp(ratio, 1.0 - clip, 1.0 + clip)
    pg_loss = torch.max(pg_unclipped, pg_clipped).mean()  # eq:actor
    v_loss = 0.5 * ((new_values - returns) ** 2).mean()  # eq:critic: mean squared advantage
    ent = entropy.mean()
    loss = pg_loss - ent_coef * ent + vf_coef * v_loss
    return {"loss": loss, "pg_loss": pg_loss, "v_loss": v_loss, "entropy": ent, "ratio": ratio}


@dataclass
class Batch:
    """Whole episodes of E days × U drones × T windows, as tensors."""

    obs: torch.Tensor  # (T, E, U, D)
    actions: torch.Tensor  # (T, E, U)
    logp: torch.Tensor  # (T, E, U)
    mask: torch.Tensor  # (T, E, U, L)
    advantages: torch.Tensor  # (T, E, U)
    returns: torch.Tensor  # (T, E, U)
    teacher: torch.Tensor | None = None  # (T, E, U) imitation targets, -1 for none


def make_batch(
    obs: np.ndarray,
    actions: np.ndarray,
    logp: np.ndarray,
    mask: np.ndarray,
    rewards: np.ndarray,
    critic: Critic,
    tcfg: TrainConfig,
    teacher: np.ndarray | None = None,
) -> Batch:
    """Evaluate the critic on the rollouts and compute GAE (arrays are ``(T, E, U, ...)``)."""
    obs_t = torch.from_numpy(obs)
    with torch.no_grad():
        values = critic(obs_t).numpy().astype(np.float64)
    adv, ret = gae(rewards, values, tcfg.gamma, tcfg.gae_lambda)
    return Batch(
        obs=obs_t,
        actions=torch.from_numpy(actions),
        logp=torch.from_numpy(logp),
        mask=torch.from_numpy(mask),
        advantages=torch.from_numpy(adv.astype(np.float32)),
        returns=torch.from_numpy(ret.astype(np.float32)),
        teacher=None if teacher is None else torch.from_numpy(teacher.astype(np.int64)),
    )


def ppo_update(
    actor: Actor,
    critic: Critic,
    optimizer: torch.optim.Optimizer,
    batch: Batch,
    tcfg: TrainConfig,
    generator: torch.Generator,
    bc_coef: float = 0.0,
) -> dict[str, float]:
    """``update_epochs`` passes of minibatch SGD; returns the mean of each loss term.

    A minibatch is a set of whole (episode, drone) sequences, about H transitions
    (paper: H = 64) in all: the GRU is unrolled over those days only, from a zero
    hidden state as in the rollout, so hidden states are exact, gradients flow through
    time, and one epoch unrolls every sequence once. With ``bc_coef > 0`` and imitation
    targets in the batch, the loss adds ``bc_coef`` × the cross-entropy of the actor
    against them (an imitation term on the states PPO itself visits).
    """
    t_, e_, u_, d_ = batch.obs.shape
    n_seq = e_ * u_

    def seq(x: torch.Tensor) -> torch.Tensor:
        """``(T, E, U, ...)`` -> ``(T, E·U, ...)``: one column per (episode, drone)."""
        return x.reshape(t_, n_seq, *x.shape[3:])

    seq_obs = seq(batch.obs)
    critic_in = seq(fleet_input(batch.obs))
    actions, old_logp = seq(batch.actions), seq(batch.logp)
    teacher = seq(batch.teacher) if batch.teacher is not None else None
    use_bc = bc_coef > 0 and teacher is not None and bool((teacher >= 0).any())
    mask, adv_all, ret_all = seq(batch.mask), seq(batch.advantages), seq(batch.returns)
    per_mb = max(1, tcfg.minibatch // max(1, t_))  # sequences per minibatch
    params = [*actor.parameters(), *critic.parameters()]
    sums: dict[str, float] = {
        "pg_loss": 0.0,
        "v_loss": 0.0,
        "entropy": 0.0,
        "approx_kl": 0.0,
        "clipfrac": 0.0,
        "bc_loss": 0.0,
    }
    steps = 0
    for _ in range(tcfg.update_epochs):
        perm = torch.randperm(n_seq, generator=generator)
        for start in range(0, n_seq, per_mb):
            cols = perm[start : start + per_mb]
            logits = actor.unroll(seq_obs[:, cols]).reshape(-1, mask.shape[-1])
            m = mask[:, cols].reshape(logits.shape)
            dist = Categorical(logits=logits.masked_fill(~m, MASKED_LOGIT))
            adv = adv_all[:, cols].reshape(-1)
            if tcfg.norm_adv and adv.numel() > 1:
                adv = (adv - adv.mean()) / (adv.std() + 1e-8)
            terms = ppo_loss(
                dist.log_prob(actions[:, cols].reshape(-1)),
                old_logp[:, cols].reshape(-1),
                adv,
                critic.net(critic_in[:, cols]).reshape(-1),
                ret_all[:, cols].reshape(-1),
                dist.entropy(),
                tcfg.clip,
                tcfg.vf_coef,
                tcfg.ent_coef,
            )
            loss = terms["loss"]
            if use_bc:
                assert teacher is not None
                tgt = teacher[:, cols].reshape(-1)
                has = tgt >= 0
                if bool(has.any()):
                    bc = -dist.log_prob(tgt.clamp(min=0))[has].mean()
                    loss = loss + bc_coef * bc
                    sums["bc_loss"] += float(bc.detach())
            optimizer.zero_grad()
            loss.backward()
            nn.utils.clip_grad_norm_(params, tcfg.max_grad_norm)
            optimizer.step()
            with torch.no_grad():
                ratio = terms["ratio"]
                sums["approx_kl"] += float(((ratio - 1) - ratio.log()).mean())  # k3 estimator
                sums["clipfrac"] += float(((ratio - 1.0).abs() > tcfg.clip).float().mean())
            for k in ("pg_loss", "v_loss", "entropy"):
                sums[k] += float(terms[k].detach())
            steps += 1
    return {k: v / max(1, steps) for k, v in sums.items()}
