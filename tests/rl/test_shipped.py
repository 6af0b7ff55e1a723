"""The shipped actors: one actor, any layout (squares, 32 depots), without retraining."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.config import OpsConfig
from marops_cli.policies.landing import (
    CONTEXT_FEATURES,
    FEATURES,
    FREE_FEATURES,
    operating_model,
)
from marops_cli.policies.observation import OBS_VERSION
from marops_cli.policies.registry import (
    DEFAULT_LANDING_NAME,
    DEFAULT_MAPPO_NAME,
    default_policy_path,
)

runner = CliRunner()
POLICIES = Path(__file__).resolve().parents[2] / "policies"


def _replay(example_csv: Path, out: Path, *extra: str) -> dict:
    res = runner.invoke(
        app, ["replay-day", str(example_csv), "--date", "0811", "--out", str(out), *extra]
    )
    assert res.exit_code == 0, res.output
    return json.loads((out / "metrics.json").read_text())["days"][0]


def test_shipped_sidecars_match_this_build() -> None:
    # The flight-range actor reads this build's observation; the MAPPO baseline keeps
    # version 2 (all drones at once, no planner in the loop, as the paper's).
    for name, version in (("marops-basic", OBS_VERSION), ("mappo-basic", 2)):
        doc = json.loads((POLICIES / f"{name}.json").read_text())
        assert doc["obs_version"] == version and doc["n_actions"] == 4
        assert doc["command"].startswith("marops train") and len(doc["data"]["sha256"]) == 64
        assert doc["data"]["origin"].startswith("marops synth")
        assert doc["episodes"] == int(doc["command"].split("--episodes ")[1].split()[0])
        assert doc["operating_model"] == "paper"
    assert default_policy_path() == POLICIES / "marops-basic.pt"
    assert default_policy_path(DEFAULT_MAPPO_NAME) == POLICIES / "mappo-basic.pt"
    # The landing actor: the default operating model's, made by the command it records.
    doc = json.loads((POLICIES / "marops-ops.json").read_text())
    assert doc["format"] == "marops-landing-actor/3"  # it reads the situation
    assert len(doc["weight"]) == len(FEATURES) + len(CONTEXT_FEATURES) + len(FREE_FEATURES)
    assert doc["features"] == [*FEATURES, *CONTEXT_FEATURES, *FREE_FEATURES]
    assert doc["operating_model"] == operating_model(OpsConfig())
    assert doc["command"].startswith("marops train") and "--algorithm es" in doc["command"]
    assert doc["data"]["origin"].startswith("marops synth")
    assert default_policy_path(DEFAULT_LANDING_NAME) == POLICIES / "marops-ops.safetensors"


PAPER = ["--config", str(Path(__file__).resolve().parents[2] / "examples" / "paper-ops.toml")]


@pytest.mark.parametrize(
    "extra",
    [
        ["--method", "marops"],  # the landing actor (the default operating model)
        ["--method", "squares"],  # the same actor on a 4 x 4 grid of squares
        ["--method", "marops", "--n-depots", "32"],  # and on twice as many areas
        ["--method", "marops", *PAPER],  # the recurrent actor (the paper's model)
        ["--method", "squares", *PAPER],
        ["--method", "mappo", *PAPER],  # the MAPPO baseline picks plans itself
    ],
    ids=["marops", "squares", "depots32", "paper", "paper-squares", "mappo"],
)
def test_actor_runs_on_any_layout(example_csv: Path, tmp_path: Path, extra: list[str]) -> None:
    m = _replay(example_csv, tmp_path, *extra)
    assert m["delivered"] > 0 and m["mean_energy_kj"] > 0
    assert m["solver"]["fallbacks"] == 0


def test_mappo_refuses_the_realistic_model(example_csv: Path, tmp_path: Path) -> None:
    res = runner.invoke(
        app,
        ["replay-day", str(example_csv), "--date", "0811", "--method", "mappo", "--out",
         str(tmp_path / "o")],
    )  # fmt: skip
    assert res.exit_code == 2 and "'paper'" in res.output and "stock=home" in res.output
    assert not (tmp_path / "o").exists()
