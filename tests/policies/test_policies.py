"""Baseline policies and the TorchScript actor loader (a tiny untrained actor)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from marops_cli.data.frame import Frame
from marops_cli.errors import InputError
from marops_cli.plans.ranges import range_table
from marops_cli.policies import (
    OBS_VERSION,
    GlobalPolicy,
    GreedyPolicy,
    RandomPolicy,
    StayPolicy,
    WindowView,
    make_policy,
    obs_dim,
    observe,
)
from marops_cli.policies.torchscript import TorchScriptPolicy
from marops_cli.segment.depots import Depots, nearest_candidates

FRAME = Frame(121.47, 31.23, 10.0)


def _view(
    delays: list[float], areas_xy: list[tuple[float, float]], drones: list[int]
) -> WindowView:
    """Three depots on a line 0 / 2 / 4 km; requests at the given places and delays."""
    xy = np.array([[0.0, 0.0], [2000.0, 0.0], [4000.0, 0.0]])
    dep = Depots("kmeans", FRAME, xy, np.zeros(3, np.int64), nearest_candidates(xy, 3))
    pxy = np.array(areas_xy, dtype=float).reshape(-1, 2)
    n = len(delays)
    return WindowView(
        t=4,
        n_windows=16,
        window_h=0.5,
        depots=dep,
        ranges=range_table(dep, 0.34),
        drone_depot=np.array(drones),
        pending_idx=np.arange(n),
        pending_xy=pxy,
        pending_area=dep.assign(pxy[:, 0], pxy[:, 1]) if n else np.zeros(0, np.int64),
        pending_delay_h=np.array(delays, dtype=float),
        pending_due_w=np.full(n, 2),
        pending_due_s=np.full(n, 3600.0),
        pending_weight=np.full(n, 0.5),
    )


def test_stay_and_global_choose_action_zero() -> None:
    view = _view([1.0], [(4000.0, 0.0)], [0, 1])
    assert StayPolicy().act(view).tolist() == [0, 0]
    assert GlobalPolicy().act(view).tolist() == [0, 0]
    assert GlobalPolicy.scope == "global"


def test_random_is_seeded_and_in_range() -> None:
    view = _view([1.0], [(4000.0, 0.0)], [0, 1, 2] * 10)
    a, b = RandomPolicy(5), RandomPolicy(5)
    acts = [a.act(view) for _ in range(3)]
    assert all(np.array_equal(x, b.act(view)) for x in acts)
    assert all(((x >= 0) & (x < 3)).all() for x in acts)
    a.reset(5)
    assert np.array_equal(a.act(view), acts[0])
    assert len({tuple(x) for x in acts}) > 1


def test_greedy_flies_towards_late_work() -> None:
    # Drone at depot 0; 3 h of delay waits at depot 2 (4 km), nothing elsewhere.
    view = _view([3.0], [(4000.0, 100.0)], [0])
    cand = view.depots.candidates[0].tolist()  # [0, 1, 2]
    assert cand[GreedyPolicy().act(view)[0]] == 2
    # With the same delay at its own depot too, staying wins (no flight needed).
    view = _view([3.0, 3.0], [(4000.0, 100.0), (100.0, 0.0)], [0])
    assert GreedyPolicy().act(view)[0] == 0


def test_observation_is_layout_independent_in_shape() -> None:
    view = _view([1.0, 0.0], [(4000.0, 0.0), (10.0, 10.0)], [0, 2])
    obs = observe(view)
    assert obs.shape == (2, obs_dim(3)) and obs.dtype == np.float32
    assert np.isfinite(obs).all()


class _TinyActor(torch.nn.Module):
    """forward(obs, hidden) -> (logits, hidden), untrained."""

    def __init__(self, n_obs: int, n_actions: int, hidden: int) -> None:
        super().__init__()
        self.gru = torch.nn.GRUCell(n_obs, hidden)
        self.head = torch.nn.Linear(hidden, n_actions)

    def forward(self, obs: torch.Tensor, hidden: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        h = self.gru(obs, hidden)
        return self.head(h), h


def _export(tmp_path: Path, n_actions: int = 3, version: int = OBS_VERSION) -> Path:
    torch.manual_seed(0)
    actor = torch.jit.script(_TinyActor(obs_dim(n_actions), n_actions, 8))
    path = tmp_path / "tiny.pt"
    actor.save(str(path))
    side = {"obs_version": version, "n_actions": n_actions, "hidden_size": 8}
    path.with_suffix(".json").write_text(json.dumps(side))
    return path


def test_torchscript_actor_loads_and_acts_deterministically(tmp_path: Path) -> None:
    path = _export(tmp_path)
    view = _view([1.0, 0.5], [(4000.0, 0.0), (2000.0, 50.0)], [0, 1, 2])
    p1 = make_policy(f"torchscript:{path}")
    p2 = TorchScriptPolicy(path)
    first = p1.act(view)
    assert first.shape == (3,) and ((first >= 0) & (first < 3)).all()
    assert np.array_equal(first, p2.act(view))
    # The hidden state carries over windows; reset() starts the day again.
    p1.act(view)
    p1.reset(0)
    assert np.array_equal(p1.act(view), first)
    # The action is the arg-max of the module's own logits.
    module = torch.jit.load(str(path))
    obs = torch.from_numpy(observe(view))
    logits, _ = module(obs, torch.zeros(3, 8))
    assert first.tolist() == logits.argmax(dim=1).tolist()


def test_torchscript_actor_mismatches_are_input_errors(tmp_path: Path) -> None:
    view = _view([1.0], [(4000.0, 0.0)], [0])
    with pytest.raises(InputError, match="expects 4 actions"):
        TorchScriptPolicy(_export(tmp_path, n_actions=4)).act(view)
    with pytest.raises(InputError, match="observation version"):
        TorchScriptPolicy(_export(tmp_path, version=OBS_VERSION + 7))
    (tmp_path / "tiny.json").unlink()
    with pytest.raises(InputError, match="sidecar beside the .pt file not found"):
        TorchScriptPolicy(tmp_path / "tiny.pt")
    with pytest.raises(InputError, match="unknown policy"):
        make_policy("clever")
