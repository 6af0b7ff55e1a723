"""Tiny training data for the RL tests: 3 synthetic days with few orders (fast episodes)."""

from __future__ import annotations

from pathlib import Path

import pytest

from marops_cli.config import PlannerConfig
from marops_cli.data.synth import SynthConfig, generate, write
from marops_cli.rl.config import TrainConfig


@pytest.fixture(scope="session")
def tiny_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """3 days (2 for training, 1 held out), about 100 requests a day in the study area."""
    path = tmp_path_factory.mktemp("rl") / "tiny.csv"
    write(generate(SynthConfig(days=3, seed=5, orders_per_day=500)), path)
    return path


@pytest.fixture()
def small_cfg() -> PlannerConfig:
    """4 drones, 8 depots, 8 windows: a day is a fraction of a second."""
    cfg = PlannerConfig()
    cfg.sim.drones = 4
    cfg.segment.n_depots = 8
    cfg.data.windows = 8
    return cfg


def quick(**fields: object) -> TrainConfig:
    """A few episodes, two per update, one worker, small minibatches."""
    base: dict[str, object] = {
        "episodes": 4,
        "episodes_per_update": 2,
        "workers": 1,
        "minibatch": 16,
        "update_epochs": 2,
        "eval_every": 4,
        "checkpoint_every": 2,
    }
    return TrainConfig(**{**base, **fields})  # type: ignore[arg-type]
