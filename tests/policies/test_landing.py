"""The landing actor (docs/method.md §6.1): its features checked by hand, backlog as a
special case, its data-only file and the operating model it was trained for."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.config import OpsConfig, PlannerConfig
from marops_cli.errors import InputError
from marops_cli.policies import BacklogPolicy, make_policy
from marops_cli.policies.landing import (
    BACKLOG_WEIGHTS,
    FEATURES,
    DepotState,
    LandingActor,
    landing_features,
    operating_model,
)
from marops_cli.rl.es import write_landing_actor

from .test_rules import FAR, _view

REALISTIC = "stock=home, batteries, busy"


def _side(model: str = REALISTIC) -> dict:
    return {"format": "marops-landing-actor/1", "operating_model": model}


def test_features_by_hand() -> None:
    # Depots at 0, 1 km and 3 km; two parcels at depot 1 (delays 0.5 h and 1.5 h), one
    # at depot 2; drones at depots 0 and 1; 2 requests expected at depot 2 next window.
    view = _view([0.0, 1000.0, 3000.0], [1, 1, 2], [0, 1], [0.5, 1.5, 0.0], arrivals={2: 2.0})
    view = replace(view, depot_spares=np.array([0, 1, 2]), depot_charging=np.array([3, 0, 0]))
    depots = DepotState(view)
    there = np.array([0.0, 1.0, 0.0])  # drone 0 chooses; drone 1 is still at depot 1
    f = landing_features(view, depots, 0, there)
    dests = view.depots.candidates[0]
    assert list(dests) == [0, 1, 2]
    lg = np.log1p
    # value at depot 1: (1 + 0.5) + (1 + 1.5) = 4; one drone there.
    want_1 = [lg(4.0), lg(1.0), lg(2.0), lg(2.0), 1.0, 0.0, 0.0, lg(1.0), 0.0, 0.0]
    assert f[1, :10] == pytest.approx(want_1, abs=1e-12)
    # depot 2: value 1, nobody there, 3 km, 2 expected, 2 spares.
    want_2 = [lg(1.0), 0.0, lg(1.0), lg(1.0), 3.0, lg(2.0), lg(2.0), lg(2.0), 0.0, 0.0]
    assert f[2, :10] == pytest.approx(want_2, abs=1e-12)
    # staying: no parcels, 3 batteries charging, the stay flag.
    assert f[0, 8] == pytest.approx(lg(3.0)) and f[0, 9] == 1.0
    t = view.t / view.n_windows
    assert f[2, 10] == pytest.approx(t * lg(1.0)) and f[2, 11] == pytest.approx(t * 3.0)
    assert f.shape == (3, len(FEATURES))


def test_backlog_weights_are_backlog() -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        stock = list(rng.integers(0, 4, size=6))
        drones = list(rng.integers(0, 4, size=3))
        delays = list(rng.uniform(0, 2, size=6))
        view = _view([0.0, 800.0, 1600.0, FAR], stock, drones, delays)
        mine = LandingActor(BACKLOG_WEIGHTS).act(view)
        assert np.array_equal(mine, BacklogPolicy().act(view))


def test_weights_choose_and_reach() -> None:
    # Weight only on distance: the actor prefers the farthest destination it can reach,
    # never the one out of reach.
    view = _view([0.0, 800.0, 1600.0, FAR], [1], [0])
    w = np.zeros(len(FEATURES))
    w[FEATURES.index("distance km")] = 1.0
    assert list(LandingActor(w).act(view)) == [2]
    held = _view([0.0, 800.0, 1600.0, FAR], [1], [0], ready=[False])
    assert list(LandingActor(w).act(held)) == [0]  # a drone that cannot fly stays


def test_operating_model_names() -> None:
    assert operating_model(OpsConfig()) == REALISTIC
    assert operating_model(OpsConfig.paper_model()) == "paper"
    assert operating_model(OpsConfig(busy=False)) == "stock=home, batteries"


def test_file_round_trip(tmp_path: Path) -> None:
    w = np.linspace(-1.0, 1.0, len(FEATURES))
    write_landing_actor(w, tmp_path / "a.safetensors", _side())
    pol = make_policy(str(tmp_path / "a.safetensors"), model=REALISTIC)
    assert isinstance(pol, LandingActor)
    assert pol.weight == pytest.approx(w.astype(np.float32), abs=0)
    assert pol.identity == tmp_path / "a.safetensors"
    with pytest.raises(InputError, match="trained for the operating model"):
        make_policy(str(tmp_path / "a.safetensors"))  # the paper's model
    with pytest.raises(InputError, match="trained for the operating model"):
        pol.configure(PlannerConfig(ops=OpsConfig.paper_model()))


@pytest.mark.parametrize(
    ("tensors", "side", "match"),
    [
        ({"weight": np.zeros(5, np.float32)}, _side(), "expected float32"),
        ({"weight": np.zeros(12, np.float64)}, _side(), "expected float32"),
        ({"weight": np.full(12, np.nan, np.float32)}, _side(), "NaN or infinite"),
        ({"weight": np.zeros(12, np.float32), "x": np.zeros(1, np.float32)}, _side(), "one tensor"),
        ({"weight": np.zeros(12, np.float32)}, {"format": "marops-landing-actor/1"}, "operating"),
        (
            {"weight": np.zeros(12, np.float32)},
            {"format": "marops-basic", "operating_model": REALISTIC},
            "expected format 'marops-landing-actor/1', got 'marops-basic'",
        ),
        ({"weight": np.zeros(12, np.float32)}, {"operating_model": REALISTIC}, "got None"),
        ({"weight": np.zeros(12, np.float32)}, [REALISTIC], "expected a JSON object, got list"),
    ],
    ids=["shape", "dtype", "nan", "extra", "no-model", "format", "no-format", "not-object"],
)
def test_bad_files(tmp_path: Path, tensors: dict, side: object, match: str) -> None:
    from safetensors.numpy import save_file

    save_file(tensors, str(tmp_path / "a.safetensors"))
    (tmp_path / "a.json").write_text(json.dumps(side))
    with pytest.raises(InputError, match=match):
        make_policy(str(tmp_path / "a.safetensors"), model=REALISTIC)


def test_cli_refuses_another_model(example_csv: Path, tmp_path: Path) -> None:
    write_landing_actor(BACKLOG_WEIGHTS, tmp_path / "a.safetensors", _side())
    paper = tmp_path / "paper.toml"
    paper.write_text('[ops]\nstock = "any"\nbatteries_per_depot = "unlimited"\nbusy = false\n')
    args = ["replay-day", str(example_csv), "--date", "0811", "--method", "marops"]
    args += ["--policy", str(tmp_path / "a.safetensors"), "--config", str(paper)]
    res = CliRunner().invoke(app, [*args, "--out", str(tmp_path / "out")])
    assert res.exit_code == 2
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and "'stock=home, batteries, busy'" in lines[0] and "'paper'" in lines[0]
    assert not (tmp_path / "out").exists()
