"""The exported actor: same actions after reloading, loadable without the training code."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from marops_cli.policies.observation import (
    OBS_VERSION,
    OBS_VERSIONS,
    ObsVersion,
    n_choices,
    obs_dim,
)
from marops_cli.policies.torchscript import TorchScriptPolicy
from marops_cli.rl.export import write_actor
from marops_cli.rl.networks import Actor

# torch 2.13 deprecates TorchScript; docs/method.md §6 names it as the artifact format.
pytestmark = pytest.mark.filterwarnings("ignore:`torch.jit:DeprecationWarning")


def _actor(seed: int = 3) -> Actor:
    torch.manual_seed(seed)
    actor = Actor(obs_dim(4), n_choices(4), 64)  # 4 destinations and the free landing
    with torch.no_grad():  # non-trivial logits: the head starts near zero
        actor.head.weight.normal_(0.0, 1.0)
    return actor


def _fixed_obs() -> torch.Tensor:
    g = torch.Generator().manual_seed(0)
    return torch.rand(5, obs_dim(4), generator=g) * 3.0


def test_reloaded_actor_gives_the_same_actions(tmp_path: Path) -> None:
    actor = _actor()
    path = tmp_path / "p.pt"
    doc, recorded = write_actor(actor, path, {"alpha": 0.5})
    assert recorded
    assert doc["n_actions"] == 4 and json.loads(path.with_suffix(".json").read_text()) == doc
    obs, h0 = _fixed_obs(), torch.zeros(5, 64)
    with torch.no_grad():
        want, want_h = actor(obs, h0)
        got, got_h = torch.jit.load(str(path))(obs, h0)
    torch.testing.assert_close(got, want, rtol=0, atol=0)
    torch.testing.assert_close(got_h, want_h, rtol=0, atol=0)
    assert torch.equal(got.argmax(1), want.argmax(1))
    # Through the policy loader, a second step uses the carried hidden state.
    pol = TorchScriptPolicy(path)
    assert pol.n_actions == 4 and pol.hidden_size == 64


def test_sidecar_writes_the_observation_version_as_a_plain_number(tmp_path: Path) -> None:
    """Named versions in the code, the bare number in the file (byte-stable sidecars)."""
    assert [int(v) for v in OBS_VERSIONS] == [2, 3, 4, 5]
    assert OBS_VERSION is ObsVersion.ANTICIPATION == 4
    assert (ObsVersion.MAPPO, ObsVersion.SEQUENTIAL) == (2, 3)
    path = tmp_path / "p.pt"
    write_actor(_actor(), path, {})
    text = path.with_suffix(".json").read_text()
    assert '"obs_version": 4,' in text and "ObsVersion" not in text
    assert type(json.loads(text)["obs_version"]) is int
    assert TorchScriptPolicy(path).obs_version is ObsVersion.ANTICIPATION


def test_loads_with_plain_torch_in_a_fresh_process(tmp_path: Path) -> None:
    path = tmp_path / "p.pt"
    actor = _actor()
    write_actor(actor, path, {})
    obs = _fixed_obs()
    with torch.no_grad():
        want = actor(obs, torch.zeros(5, 64))[0].argmax(1).tolist()
    np.save(tmp_path / "obs.npy", obs.numpy())
    code = f"""
import sys, json, numpy as np, torch
m = torch.jit.load({str(path)!r})
obs = torch.from_numpy(np.load({str(tmp_path / "obs.npy")!r}))
logits, h = m(obs, torch.zeros(obs.shape[0], 64))
from marops_cli.policies.torchscript import TorchScriptPolicy  # the CLI's loader
TorchScriptPolicy({str(path)!r})
bad = sorted(k for k in sys.modules if k.startswith("marops_cli.rl"))
print(json.dumps({{"actions": logits.argmax(1).tolist(), "rl": bad}}))
"""
    res = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    )
    got = json.loads(res.stdout.strip().splitlines()[-1])
    assert got["rl"] == [], "loading an actor must not import the training code"
    assert got["actions"] == want
