"""The reward of eq. (10) and one episode of the multi-agent environment."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.testing import assert_allclose

from marops_cli.config import PlannerConfig
from marops_cli.rl.config import TrainConfig
from marops_cli.rl.env import DeliveryEnv, reward, squash
from marops_cli.rl.train import load_training_data, split_days


def test_squash_and_reward() -> None:
    assert_allclose(squash(np.array([0.0, 3.0]), 3.0), [0.0, 0.5], atol=1e-12)
    assert 0.99 < squash(np.array([20.0]), 1.0)[0] <= 1.0  # saturates towards 1
    tcfg = TrainConfig(delay_scale_h=2.0, energy_scale_kj=40.0)
    # both terms at their scale: -(1 - a) * 0.5 - a * 0.5 = -0.5 whatever alpha
    assert_allclose(reward(np.array([2.0]), np.array([40.0]), 0.2, tcfg), [-0.5], atol=1e-12)
    # alpha weighs energy: no delay, energy at scale -> -alpha * 0.5
    assert_allclose(reward(np.array([0.0]), np.array([40.0]), 0.2, tcfg), [-0.1], atol=1e-12)


def test_split_days_is_80_20() -> None:
    import datetime as dt

    days = [dt.date(2022, 8, 1) + dt.timedelta(days=i) for i in range(10)]
    train, held = split_days(days)
    assert train == days[:8] and held == days[8:]
    train, held = split_days(days, [days[0], days[5]])
    assert train == [days[0], days[5]] and len(held) == 8


def test_episode_adds_up_to_the_day_delay(tiny_csv: Path, small_cfg: PlannerConfig) -> None:
    """Summed over a day, the per-window delay of the reward is the metric's delivery delay."""
    for scope in ("team", "observed"):
        tcfg = TrainConfig(reward_scope=scope)
        td = load_training_data(tiny_csv, small_cfg, tcfg)
        env = DeliveryEnv(td.ctx.depots, small_cfg, tcfg)
        day = td.ctx.train_days[0]
        env.reset(day)
        rng = np.random.default_rng(0)
        total, steps = 0.0, 0
        while not env.done:
            obs, acts = env.observe(
                lambda u, o, n=env.n_logits, g=rng: g.integers(0, n, size=len(u))
            )
            assert obs.shape == (4, env.obs_dim) and env.action_mask().shape == (4, 4)
            r, info = env.step(acts)
            assert r.shape == (4,) and np.all(r <= 0) and np.all(r > -1)
            total += float(info["late_h"])
            steps += 1
        assert steps == day.n_windows
        assert env.state is not None
        assert_allclose(total, env.state.delivery_delay_h().sum(), rtol=1e-12)
