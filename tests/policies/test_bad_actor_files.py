"""Trusted TorchScript actor files (``--trust-actor``, no weights file beside them) of
another model are one-line errors naming the file (exit 2), found by one probe call before
any planning; an actor that outputs NaN stops the run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

SIDE = {"obs_version": 3, "n_actions": 4, "hidden_size": 8, "obs_dim": 59, "n_logits": 4}


class OneArg(torch.nn.Module):
    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return obs[:, :4]


class Shaped(torch.nn.Module):
    def __init__(self, width: int, hidden: int, fill: float = 0.0) -> None:
        super().__init__()
        self.width, self.hidden, self.fill = width, hidden, fill

    def forward(self, obs: torch.Tensor, h: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        n = obs.shape[0]
        return torch.full((n, self.width), self.fill), torch.zeros((n, self.hidden))


def _actor(tmp_path: Path, module: torch.nn.Module, **side: object) -> Path:
    path = tmp_path / "actor.pt"
    torch.jit.save(torch.jit.script(module), str(path))
    path.with_suffix(".json").write_text(json.dumps({**SIDE, **side}))
    return path


CASES = {
    "forward takes one input": (lambda: OneArg(), {}, "does not run as forward(obs (59"),
    "wrong output width": (lambda: Shaped(7, 8), {}, "expected forward"),
    "other hidden size": (lambda: Shaped(4, 16), {}, "hidden (8)"),
    "non-numeric observation version": (lambda: Shaped(4, 8), {"obs_version": "three"}, "3"),
    "hidden size zero": (lambda: Shaped(4, 8), {"hidden_size": 0}, "hidden_size"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_bad_actor_file_is_one_line(example_csv: Path, tmp_path: Path, case, fails_cleanly):
    make, side, needle = CASES[case]
    path = _actor(tmp_path, make(), **side)
    args = ["replay-day", str(example_csv), "--date", "0811", "--method", "marops"]
    args += ["--policy", str(path), "--trust-actor", "--out", str(tmp_path / "out")]
    line = fails_cleanly(args, tmp_path, "actor.")
    if case == "non-numeric observation version":
        assert "obs_version" in line and "'three'" in line
    else:
        assert needle in line, line


def test_an_actor_that_outputs_nan_stops_the_run(example_csv: Path, tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    path = _actor(tmp_path, Shaped(4, 8, float("nan")))
    args = ["replay-day", str(example_csv), "--date", "0811", "--method", "marops"]
    args += ["--policy", str(path), "--trust-actor"]
    res = CliRunner().invoke(app, [*args, "--out", str(tmp_path / "o")])
    assert res.exit_code == 1
    assert "actor.pt: the actor returned NaN or infinite logits" in res.stderr
    assert not (tmp_path / "o").exists()


def test_a_sidecar_whose_obs_dim_is_not_its_versions_is_refused(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """The shipped actor with ``obs_version`` 5 in its sidecar (102 features) but its
    network's 99: refused naming the sidecar's key, before any window is planned."""
    shipped = Path(__file__).resolve().parents[2] / "policies"
    for ext in ("pt", "safetensors", "json"):
        (tmp_path / f"actor.{ext}").write_bytes((shipped / f"marops-basic.{ext}").read_bytes())
    side = tmp_path / "actor.json"
    side.write_text(json.dumps({**json.loads(side.read_text()), "obs_version": 5}))
    args = ["replay-day", str(example_csv), "--date", "0811", "--method", "marops"]
    args += ["--policy", str(tmp_path / "actor.pt"), "--out", str(tmp_path / "out")]
    args += ["--config", str(example_csv.parent / "paper.toml")]
    line = fails_cleanly(args, tmp_path, "actor.json", "key 'obs_dim'")
    assert "obs_dim 99 disagrees with obs_version 5" in line and "102 features" in line


def test_a_weights_file_is_read_no_further_than_its_limit(tmp_path: Path) -> None:
    """A weights file is read to its limit and one byte more, never whole: a file that
    grew after its size was checked (or a device reporting none) is refused naming it."""
    import struct

    from marops_cli.errors import InputError
    from marops_cli.policies.base import read_tensors

    header = json.dumps({"w": {"dtype": "F32", "shape": [2], "data_offsets": [0, 8]}}).encode()
    path = tmp_path / "w.safetensors"
    path.write_bytes(struct.pack("<Q", len(header)) + header + b"\0" * 8)
    size = path.stat().st_size
    assert read_tensors(path, size).float32("w").tolist() == [0.0, 0.0]
    with pytest.raises(InputError, match=f"larger than {size - 1:,} bytes") as err:
        read_tensors(path, size - 1)
    assert err.value.file == str(path)
