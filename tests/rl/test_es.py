"""Training the landing actor by evolution strategies (marops_cli/rl/es.py): one
generation moves the weights, any number of workers and a resumed run end at the same
weights, and the paper's operating model is refused."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from marops_cli.config import OpsConfig, PlannerConfig
from marops_cli.errors import InputError
from marops_cli.policies import make_policy
from marops_cli.policies.landing import (
    CONTEXT_FEATURES,
    JOINT_START,
    RULE_FEATURES,
    LandingActor,
    extend_weights,
)
from marops_cli.rl.data import load_training_data
from marops_cli.rl.es import RULES, LandingTrainer, day_cost
from marops_cli.rl.train import train_actor

from .conftest import quick


def _es(**fields: object):  # noqa: ANN202
    base = {"algorithm": "es", "es_days": 1, "es_pairs": 1, "keep_best": False, "eval_every": 1000}
    return quick(**{**base, **fields})


def _weights(out: Path) -> list[float]:
    return json.loads(out.with_suffix(".ckpt").read_text())["weight"]


def test_generations_move_the_weights_and_export(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    td = load_training_data(tiny_csv, small_cfg, _es(episodes=13))
    side = train_actor(td, tmp_path / "a.safetensors", resume=False).sidecar
    assert side["operating_model"] == "stock=home, batteries, busy"
    assert side["format"] == "marops-landing-actor/2" and len(side["features"]) == 16
    assert side["generations"] == 2 and side["episodes"] >= 7
    assert not np.allclose(side["weight"], JOINT_START)  # the steps moved it
    pol = make_policy(str(tmp_path / "a.safetensors"), model=side["operating_model"])
    assert isinstance(pol, LandingActor)
    assert pol.weight == pytest.approx(side["weight"], abs=1e-6) and pol.joint
    ev = side["heldout"]
    assert set(ev["methods"]) == {"marops", "best rule"} and ev["cost"] > 0
    assert not (tmp_path / "a.pt").exists()  # data only: nothing to trust


def test_workers_and_resume_give_the_same_weights(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    one = tmp_path / "one" / "a.safetensors"
    one.parent.mkdir()
    train_actor(load_training_data(tiny_csv, small_cfg, _es(episodes=13)), one, resume=False)
    two = tmp_path / "two" / "a.safetensors"
    two.parent.mkdir()
    cut = load_training_data(tiny_csv, small_cfg, _es(episodes=4, workers=2))
    train_actor(cut, two, resume=False)  # stops after one generation
    assert _weights(two) != _weights(one)
    rest = load_training_data(tiny_csv, small_cfg, _es(episodes=13, workers=2))
    train_actor(rest, two, resume=True)
    assert _weights(two) == _weights(one)


EDITS = {
    "needs evals": lambda s: {k: v for k, v in s.items() if k != "evals"},
    "reference: expected a table, got null": lambda s: {**s, "reference": None},
    "reference.d.j: expected a number, got 'x'": lambda s: {**s, "reference": {"d": {"j": "x"}}},
    "reference.d.share: a reference needs share": lambda s: {
        **s,
        "reference": {"d": {"j": 1.0, "energy": 2.0}},
    },
    "weight: expected a list, got 'heavy'": lambda s: {**s, "weight": "heavy"},
    f"weight must be {JOINT_START.size} numbers": lambda s: {**s, "weight": [1.0]},
    "best: expected the best evaluation": lambda s: {**s, "best": 3},
    "generation: expected a whole number, got null": lambda s: {**s, "generation": None},
    "history: expected a list, got an object": lambda s: {**s, "history": {}},
    "episode: expected 0 ≤ episode ≤ 20000000, got -5": lambda s: {**s, "episode": -5},
    "generation: expected a whole number, got inf": lambda s: {**s, "generation": math.inf},
    # Counters no run reaches, and weights no actor file may hold (policies/base.py).
    "generation: expected 0 ≤ generation ≤ 10000000, got 1000": lambda s: {
        **s,
        "generation": 1e30,
    },
    "episode: expected 0 ≤ episode ≤ 20000000": lambda s: {**s, "episode": 10**30},
    "weight holds a weight of magnitude 1e+30, beyond the 1e+06 an actor's": lambda s: {
        **s,
        "weight": [1e30] * len(s["weight"]),
    },
}


def _set(key: str, value: object):  # noqa: ANN202
    return lambda s: {**s, key: value}


def _in_best(**change: object):  # noqa: ANN202
    return lambda s: {**s, "best": {**s["best"], **change}}


READ_LATER = {
    "best must be one of the evaluations": _in_best(episode=12345),
    "best.weight[0]: expected a number, got nan": _in_best(
        weight=[float("nan")] * JOINT_START.size
    ),
    "best.weight holds a weight of magnitude 2e+06, beyond the 1e+06": _in_best(
        weight=[-2e6] * JOINT_START.size
    ),
    "history[0].generation: a history entry needs": _set("history", [{"episode": 1}]),
    "evals[0].cost: expected a number": _set(
        "evals", [{"episode": 4, "cost": "low", "methods": {}}]
    ),
    "held_out_rules[0].objective_j_mj: a held-out rule": _set("held_out_rules", [{"rule": "b"}]),
    "reference.d.energy: expected a number, got inf": lambda s: {
        **s,
        "reference": {"d": {"j": 1, "energy": math.inf}},
    },
}


def test_an_edited_checkpoint_is_refused_up_front(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    """A checkpoint of this run's format and fingerprint with an edited state is one line
    naming the file: where it raised KeyError or TypeError (EDITS), and what the run reads
    back only later (the best weights at export, the evaluations, the learning curve, the
    held-out rules: READ_LATER), checked on resuming, not found by a traceback after the
    training, nor exported as NaN weights."""
    out = tmp_path / "a.safetensors"
    train_actor(load_training_data(tiny_csv, small_cfg, _es(episodes=4)), out, resume=False)
    ckpt = out.with_suffix(".ckpt")
    state = json.loads(ckpt.read_text())
    assert state["best"] and state["evals"] and state["held_out_rules"] and state["history"]
    rest = load_training_data(tiny_csv, small_cfg, _es(episodes=13))
    for needle, edit in [*EDITS.items(), *READ_LATER.items()]:
        ckpt.write_text(json.dumps(edit(state)))
        with pytest.raises(InputError) as err:
            train_actor(rest, out, resume=True)
        line = str(err.value)
        assert line.startswith(f"{ckpt}: not a landing actor's checkpoint of this run ("), line
        assert needle in line and "\n" not in line, line


def test_paper_model_is_refused(tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path) -> None:
    small_cfg.ops = OpsConfig.paper_model()
    td = load_training_data(tiny_csv, small_cfg, _es())
    with pytest.raises(InputError, match="not the paper's"):
        train_actor(td, tmp_path / "a.safetensors", resume=False)


def test_energy_above_the_slack_costs_the_weight() -> None:
    ref = {"j": 100.0, "energy": 500.0}

    def cost(j: float, e: float, weight: float, slack: float) -> float:
        return day_cost({"objective_j_mj": j, "mean_energy_kj": e}, ref, weight, slack)

    assert cost(90.0, 480.0, 10.0, 0.01) == pytest.approx(0.9)  # less energy: J alone
    assert cost(90.0, 505.0, 10.0, 0.01) == pytest.approx(0.9)  # +1 %: within the slack
    assert cost(90.0, 515.0, 10.0, 0.01) == pytest.approx(0.9 + 10 * 0.02)  # +3 %: 2 % priced
    assert cost(90.0, 515.0, 1.0, 0.0) == pytest.approx(0.9 + 0.03)  # no slack: all of it


def test_energy_per_parcel_counts_what_was_delivered() -> None:
    # The same energy per drone delivering 10 % more parcels is 1/1.1 the energy per
    # parcel: no excess; 10 % more energy for 5 % fewer parcels is 1.1 / 0.95 − 1 above.
    ref = {"j": 100.0, "energy": 500.0, "share": 0.8}

    def cost(e: float, share: float) -> float:
        row = {"objective_j_mj": 100.0, "mean_energy_kj": e, "delivered_share": share}
        return day_cost(row, ref, 2.0, per_parcel=True)

    assert cost(550.0, 0.88) == pytest.approx(1.0)
    assert cost(550.0, 0.76) == pytest.approx(1.0 + 2.0 * (1.1 / 0.95 - 1.0))
    row = {"objective_j_mj": 100.0, "mean_energy_kj": 550.0, "delivered_share": 0.88}
    assert day_cost(row, ref, 2.0) == pytest.approx(1.0 + 2.0 * 0.1)  # per drone: priced


def test_context_features_and_spares_train_a_format_3_actor(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    tcfg = _es(episodes=13, landing_features="context", es_energy_basis="parcel")
    td = load_training_data(tiny_csv, small_cfg, tcfg, spares=[1, 3])
    assert [s.cfg.ops.batteries_per_depot for s in td.ctx.scenarios] == [1, 3]
    side = train_actor(td, tmp_path / "a.safetensors", resume=False).sidecar
    assert side["format"] == "marops-landing-actor/3" and len(side["weight"]) == 22
    assert side["features"][12:18] == list(CONTEXT_FEATURES)
    assert [s["spares"] for s in side["scenarios"]] == [1, 3]
    assert "per parcel" in side["reward"]
    pol = make_policy(str(tmp_path / "a.safetensors"), model=side["operating_model"])
    assert isinstance(pol, LandingActor) and pol.context


def test_battery_regimes_set_spares_chargers_and_power_per_scenario(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    tcfg = _es(episodes=7)
    td = load_training_data(tiny_csv, small_cfg, tcfg, batteries=["scarce", "default", "ample"])
    ops = [s.cfg.ops for s in td.ctx.scenarios]
    base = small_cfg.ops
    assert [(o.batteries_per_depot, o.chargers_per_depot, o.charge_power_w) for o in ops] == [
        (1, 1, 31.0),
        (base.batteries_per_depot, base.chargers_per_depot, base.charge_power_w),
        (4, 2, 125.0),
    ]
    assert [s.name.rsplit("/", 1)[1] for s in td.ctx.scenarios] == ["scarce", "default", "ample"]
    side = train_actor(td, tmp_path / "a.safetensors", resume=False).sidecar
    assert [(s["spares"], s["chargers"], s["charge_power_w"]) for s in side["scenarios"]][::2] == [
        (1, 1, 31.0),
        (4, 2, 125.0),
    ]
    for bad, line in (({"batteries": ["lots"]}, "unknown battery regime 'lots'"),
                      ({"batteries": ["ample", "ample"]}, "regime 'ample' given twice"),
                      ({"batteries": ["ample"], "spares": [2]}, "not both")):  # fmt: skip
        with pytest.raises(InputError, match=line):
            load_training_data(tiny_csv, small_cfg, tcfg, **bad)


def test_the_best_rule_is_chosen_from_the_given_rules(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    tcfg = _es(episodes=7, es_rules=["backlog", "flow"])
    td = load_training_data(tiny_csv, small_cfg, tcfg)
    trainer = LandingTrainer(td, tmp_path / "a.safetensors")
    assert trainer.rules == ["backlog", "flow"]
    every = load_training_data(tiny_csv, small_cfg, _es(episodes=7))
    assert LandingTrainer(every, tmp_path / "b.safetensors").rules == list(RULES)
    side = train_actor(td, tmp_path / "a.safetensors", resume=False).sidecar
    assert "best rule (backlog, flow)" in side["reward"]
    assert side["train_config"]["es_rules"] == ["backlog", "flow"]
    # One generation: its day replayed with the two rules, then by w, w + σε and w − σε.
    assert (side["generations"], side["episodes"]) == (1, 2 + 3)


def test_rule_features_train_a_format_4_actor_from_a_given_start(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    start = list(np.linspace(-0.5, 0.5, 22))  # a /3 actor's weights
    tcfg = _es(episodes=7, landing_features="rules", landing_start=start)
    td = load_training_data(tiny_csv, small_cfg, tcfg)
    trainer = LandingTrainer(td, tmp_path / "a.safetensors")
    assert trainer.weight == pytest.approx(extend_weights(np.array(start), 25), abs=0)
    side = train_actor(td, tmp_path / "a.safetensors", resume=False).sidecar
    assert side["format"] == "marops-landing-actor/4" and len(side["weight"]) == 25
    assert side["features"][18:21] == list(RULE_FEATURES)
    pol = make_policy(str(tmp_path / "a.safetensors"), model=side["operating_model"])
    assert isinstance(pol, LandingActor) and pol.context and pol.weight.size == 25


def test_training_the_new_weights_only_keeps_the_given_ones(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    start = np.linspace(-0.5, 0.5, 22).astype(np.float32).astype(np.float64)
    tcfg = _es(
        episodes=13, landing_features="rules", landing_start=list(start), landing_train="new"
    )
    td = load_training_data(tiny_csv, small_cfg, tcfg)
    side = train_actor(td, tmp_path / "a.safetensors").sidecar
    w = np.array(_weights(tmp_path / "a.safetensors"))
    assert side["generations"] == 2
    assert w[:18] == pytest.approx(start[:18], abs=0) and w[21:] == pytest.approx(start[18:], abs=0)
    assert np.abs(w[18:21]).sum() > 0  # the flow rule's three moved
    with pytest.raises(InputError, match="needs an actor to start from"):
        LandingTrainer(load_training_data(tiny_csv, small_cfg, _es(landing_train="new")), tmp_path)


def test_a_day_lost_costs_the_loss_weight_more() -> None:
    ref = {"j": 100.0, "energy": 500.0}

    def cost(j: float, loss: float) -> float:
        row = {"objective_j_mj": j, "mean_energy_kj": 500.0}
        return day_cost(row, ref, 1.0, 0.0, loss)

    assert cost(90.0, 2.0) == pytest.approx(0.9)  # a day won: J alone
    assert cost(110.0, 2.0) == pytest.approx(1.1 + 2 * 0.1)  # lost by 10 %: 30 % in all
    assert cost(110.0, 0.0) == pytest.approx(1.1)


@pytest.mark.parametrize("field", ["es_energy_weight", "es_loss_weight"])
def test_the_cost_weights_are_bounded_so_costs_stay_finite(field: str) -> None:
    """``--loss-weight 1e308`` (or ``--energy-weight``) was taken: a day lost by more
    than 80 % cost infinity, and after minutes of training the checkpoint could not be
    written (a traceback, exit 1). At most 1000, where a day a billion times worse than
    the best rule on every count still costs a finite number."""
    from pydantic import ValidationError

    from marops_cli.rl.config import MAX_ES_WEIGHT, TrainConfig

    with pytest.raises(ValidationError, match="less than or equal to 1000"):
        TrainConfig(**{field: 1e308})
    assert getattr(TrainConfig(**{field: MAX_ES_WEIGHT}), field) == MAX_ES_WEIGHT
    ref = {"j": 1e-12, "energy": 1e-12, "share": 1.0}
    row = {"objective_j_mj": 1e9, "mean_energy_kj": 1e9, "delivered_share": 1e-12}
    worst = day_cost(row, ref, MAX_ES_WEIGHT, 0.0, MAX_ES_WEIGHT, per_parcel=True)
    assert math.isfinite(worst)
