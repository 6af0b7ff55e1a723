"""The reward of eq. (10) and one episode of the multi-agent environment."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from marops_cli.config import PlannerConfig
from marops_cli.errors import InputError
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


def test_a_day_with_no_request_in_service_hours_is_left_out(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    """A day whose deliveries all fall outside service hours teaches nothing: training
    leaves it out (it stopped the run, naming the day)."""
    import csv

    rows = list(csv.reader(tiny_csv.open(newline="")))
    head = rows[0]
    acc, dlv, ds = head.index("accept_time"), head.index("delivery_time"), head.index("ds")
    for r in rows[1:]:
        if r[ds] == "802":
            r[acc], r[dlv] = "08-02 20:00:00", "08-02 21:00:00"
    path = tmp_path / "evening.csv"
    with path.open("w", newline="") as f:
        csv.writer(f).writerows(rows)
    td = load_training_data(path, small_cfg, TrainConfig())
    assert td.files[0]["train_days"] == ["2022-08-01"]
    assert td.files[0]["heldout_days"] == ["2022-08-03"]
    assert [len(s.train_days) for s in td.ctx.scenarios] == [1]
    # Asked for by --dates, the same day is an error naming it, as evaluate's is.
    with pytest.raises(InputError, match="no requests on 2022-08-02"):
        load_training_data(path, small_cfg, TrainConfig(), train=[dt.date(2022, 8, 2)])


def test_episode_adds_up_to_the_day_delay(tiny_csv: Path, small_cfg: PlannerConfig) -> None:
    """Summed over a day, the per-window delay of the reward is the metric's delivery delay."""
    for scope in ("team", "observed"):
        tcfg = TrainConfig(reward_scope=scope)
        td = load_training_data(tiny_csv, small_cfg, tcfg)
        env = DeliveryEnv(td.ctx.scenarios[0].depots, small_cfg, tcfg)
        day = td.ctx.scenarios[0].train_days[0]
        env.reset(day)
        rng = np.random.default_rng(0)
        total, steps = 0.0, 0
        while not env.done:
            obs, acts = env.observe(
                lambda u, o, n=env.n_logits, g=rng: g.integers(0, n, size=len(u))
            )
            assert obs.shape == (4, env.obs_dim) and env.action_mask().shape == (4, 5)  # + free
            r, info = env.step(acts)
            assert r.shape == (4,) and np.all(r <= 0) and np.all(r > -1)
            total += float(info["late_h"])
            steps += 1
        assert steps == day.n_windows
        assert env.state is not None
        assert_allclose(total, env.state.delivery_delay_h().sum(), rtol=1e-12)


def test_an_episode_flies_at_its_own_alpha(tiny_csv: Path, small_cfg: PlannerConfig) -> None:
    """reset(alpha=...) prices the selection, the observation and the reward at that α."""
    from marops_cli.policies.observation import GLOBAL_V4, per_action

    tcfg = TrainConfig()
    td = load_training_data(tiny_csv, small_cfg, tcfg)
    scn = td.ctx.scenarios[0]
    env = DeliveryEnv(scn.depots, small_cfg, tcfg)
    g0 = (env.n_dest + 1) * per_action(env.obs_version)  # destinations and the free landing
    assert env.obs_version == 4 and env.obs_dim == g0 + GLOBAL_V4
    rewards = {}
    for alpha in (0.2, 0.8):
        env.reset(scn.train_days[0], alpha=alpha)
        assert env.plan_cfg.alpha == alpha and env.cfg.plan.alpha == 0.5
        obs, acts = env.observe(lambda u, o: np.zeros(len(u), dtype=np.int64))
        assert np.allclose(obs[:, g0 + 7], alpha)
        r, info = env.step(acts)
        want = reward(info["delay_h"], info["energy_kj"], alpha, tcfg)
        assert_allclose(r, want, rtol=1e-12)
        rewards[alpha] = r
    env.reset(scn.train_days[0])
    assert env.alpha == 0.5 and env.how is env.base_how


def test_a_day_with_nothing_to_plan_is_left_out_of_training(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    """One delivery past midnight after the last day adds a held-out day with nothing due
    in service hours: it is left out (a day with no request teaches nothing), where it
    stopped the run with "no requests on 2022-08-04"."""
    data = tmp_path / "straggler.csv"
    row = "999999,1,Shanghai,7,121.34,31.13,1,2,08-03 23:50:00,,,,08-04 00:20:00,,,,804"
    data.write_text(tiny_csv.read_text(encoding="utf-8") + row + "\n", encoding="utf-8")
    td = load_training_data(data, small_cfg, TrainConfig())
    assert td.files[0]["train_days"] == ["2022-08-01", "2022-08-02", "2022-08-03"]
    assert td.files[0]["heldout_days"] == []
    assert len(td.ctx.scenarios[0].train_days) == 3 and td.ctx.scenarios[0].eval_days == []
