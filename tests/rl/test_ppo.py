"""GAE and the PPO loss against values computed by hand."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from numpy.testing import assert_allclose

from marops_cli.rl.ppo import gae, ppo_loss


def test_gae_hand_computed() -> None:
    # r = [1, 2, 3], V = [0.5, 1.0, 1.5], gamma = lambda = 0.5, the day ends after t = 2:
    # d2 = 3 - 1.5 = 1.5                     A2 = 1.5
    # d1 = 2 + 0.5*1.5 - 1.0 = 1.75          A1 = 1.75 + 0.25*1.5 = 2.125
    # d0 = 1 + 0.5*1.0 - 0.5 = 1.0           A0 = 1.0 + 0.25*2.125 = 1.53125
    r = np.array([[1.0], [2.0], [3.0]])
    v = np.array([[0.5], [1.0], [1.5]])
    adv, ret = gae(r, v, gamma=0.5, lam=0.5)
    assert_allclose(adv[:, 0], [1.53125, 2.125, 1.5], rtol=0, atol=1e-12)
    assert_allclose(ret[:, 0], [2.03125, 3.125, 3.0], rtol=0, atol=1e-12)


def test_gae_limits() -> None:
    r = np.array([[1.0], [2.0], [3.0]])
    v = np.array([[0.5], [1.0], [1.5]])
    # lambda = 1: Monte-Carlo returns G = [1 + 0.5*3.5, 2 + 0.5*3, 3] = [2.75, 3.5, 3].
    _, ret = gae(r, v, gamma=0.5, lam=1.0)
    assert_allclose(ret[:, 0], [2.75, 3.5, 3.0], atol=1e-12)
    # lambda = 0: the one-step TD error of the paper's advantage equation.
    adv, _ = gae(r, v, gamma=0.5, lam=0.0)
    assert_allclose(adv[:, 0], [1.0, 1.75, 1.5], atol=1e-12)
    # A bootstrap value after the last step enters the last TD error.
    adv, _ = gae(r, v, gamma=0.5, lam=0.0, last_value=np.array([2.0]))
    assert_allclose(adv[-1, 0], 3 + 0.5 * 2.0 - 1.5, atol=1e-12)


def test_ppo_loss_hand_computed() -> None:
    # ratios 1.5, 0.5, 0.5, 1.5 with advantages +1, -1, +1, -1 and clip 0.2:
    # max(-A r, -A clip(r)) = max(-1.5, -1.2), max(0.5, 0.8), max(-0.5, -0.8), max(1.5, 1.2)
    #                       = -1.2, 0.8, -0.5, 1.5  -> mean 0.15
    ratio = torch.tensor([1.5, 0.5, 0.5, 1.5], dtype=torch.float64)
    old = torch.zeros(4, dtype=torch.float64)
    adv = torch.tensor([1.0, -1.0, 1.0, -1.0], dtype=torch.float64)
    values = torch.tensor([1.0, 2.0, 3.0, 4.0], dtype=torch.float64)
    returns = torch.tensor([0.0, 2.0, 5.0, 4.0], dtype=torch.float64)  # v_loss = 0.5*5/4
    entropy = torch.ones(4, dtype=torch.float64)
    t = ppo_loss(ratio.log(), old, adv, values, returns, entropy, 0.2, 0.5, 0.01)
    assert_allclose(float(t["pg_loss"]), 0.15, atol=1e-12)
    assert_allclose(float(t["v_loss"]), 0.625, atol=1e-12)
    assert_allclose(float(t["entropy"]), 1.0, atol=1e-12)
    assert_allclose(float(t["loss"]), 0.15 - 0.01 * 1.0 + 0.5 * 0.625, atol=1e-12)


def test_ppo_loss_gradient_is_zero_where_clipped() -> None:
    # A positive advantage with the ratio already above 1 + eps: no push further up.
    logp = torch.tensor([np.log(1.5)], dtype=torch.float64, requires_grad=True)
    zero = torch.zeros(1, dtype=torch.float64)
    one = torch.ones(1, dtype=torch.float64)
    t = ppo_loss(logp, zero, one, zero, zero, zero, 0.2, 0.0, 0.0)
    t["loss"].backward()
    assert logp.grad is not None and float(logp.grad) == 0.0


def test_imitation_term_is_the_cross_entropy_to_the_targets() -> None:
    """With the imitation weight on and every PPO term zeroed (no advantage, critic on
    target, no entropy bonus), one update step lowers exactly the cross-entropy."""
    from marops_cli.rl.config import TrainConfig
    from marops_cli.rl.networks import Actor, Critic
    from marops_cli.rl.ppo import Batch, ppo_update

    torch.manual_seed(0)
    t_, e_, u_, d_, a_ = 3, 1, 2, 5, 4
    actor, critic = Actor(d_, a_, 8), Critic(d_, 8)
    obs = torch.rand(t_, e_, u_, d_)
    teacher = torch.tensor([[[1, 3]], [[1, -1]], [[2, 0]]])
    with torch.no_grad():
        logp0 = torch.log_softmax(actor.unroll(obs.reshape(t_, e_ * u_, d_)), -1)
    has = teacher.reshape(-1) >= 0
    tgt = teacher.reshape(-1).clamp(min=0)
    ce0 = float(-logp0.reshape(-1, a_)[torch.arange(6), tgt][has].mean())
    batch = Batch(
        obs=obs,
        actions=torch.zeros(t_, e_, u_, dtype=torch.int64),
        logp=torch.zeros(t_, e_, u_),
        mask=torch.ones(t_, e_, u_, a_, dtype=torch.bool),
        advantages=torch.zeros(t_, e_, u_),
        returns=torch.zeros(t_, e_, u_),
        teacher=teacher,
    )
    tcfg = TrainConfig(minibatch=64, update_epochs=1, ent_coef=0.0, vf_coef=0.0, norm_adv=False)
    opt = torch.optim.Adam(actor.parameters(), lr=1e-2)
    stats = ppo_update(actor, critic, opt, batch, tcfg, torch.Generator().manual_seed(0), 1.0)
    assert stats["bc_loss"] == pytest.approx(ce0, rel=1e-5)  # the loss it minimised
    with torch.no_grad():
        logp1 = torch.log_softmax(actor.unroll(obs.reshape(t_, e_ * u_, d_)), -1)
    ce1 = float(-logp1.reshape(-1, a_)[torch.arange(6), tgt][has].mean())
    assert ce1 < ce0  # a step towards the targets
    # Without the weight, no imitation term is computed.
    stats = ppo_update(actor, critic, opt, batch, tcfg, torch.Generator().manual_seed(0), 0.0)
    assert stats["bc_loss"] == 0.0
