"""Training end to end in seconds: artifacts, determinism, resume, worker count (the
application layer's use case, marops_cli/app/train.py)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import torch

from marops_cli.app import SILENT, Progress
from marops_cli.app.train import TrainResult, TrainSetup
from marops_cli.app.train import train as run_training
from marops_cli.config import PlannerConfig
from marops_cli.rl.config import TrainConfig

from .conftest import quick

# torch 2.13 deprecates TorchScript; docs/method.md §6 names it as the artifact format.
pytestmark = pytest.mark.filterwarnings("ignore:`torch.jit:DeprecationWarning")


class Events:
    """A progress that keeps the training loop's events from the notes it hears, and
    stops the run (Ctrl-C) once an update reaches episode ``stop_at``."""

    def __init__(self, stop_at: int | None = None) -> None:
        self.events: list[dict] = []
        self.advances = 0
        self.stop_at = stop_at

    def message(self, text: str) -> None:
        self.events.append(text.fields)  # type: ignore[attr-defined]

    def warning(self, text: str) -> None:
        raise AssertionError(text)

    def start(self, label: str, total: int, unit: str) -> None:
        self.total = total

    def advance(self, text: str = "") -> None:
        self.advances += 1
        if text:
            self.events.append(text.fields)  # type: ignore[attr-defined]
            if self.events[-1]["episode"] == self.stop_at:
                raise KeyboardInterrupt  # the run dies here

    def finish(self) -> None:
        return None


def train(
    data: Path | list[Path],
    cfg: PlannerConfig,
    tcfg: TrainConfig,
    out: Path,
    *,
    progress: Progress = SILENT,
    **options: Any,
) -> dict:
    """The sidecar of a training run of the application layer."""
    res = run_training(data, TrainSetup(cfg, tcfg, **options), out, progress=progress)
    assert isinstance(res, TrainResult) and res.actor == out
    return res.sidecar


def _weights(path: Path) -> dict[str, torch.Tensor]:
    return dict(torch.jit.load(str(path)).state_dict())


def _same(a: dict[str, torch.Tensor], b: dict[str, torch.Tensor]) -> bool:
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def test_smoke_writes_actor_sidecar_checkpoint(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    out = tmp_path / "a.pt"
    rec = Events()
    setup = TrainSetup(small_cfg, quick(), command="marops x")
    res = run_training(tiny_csv, setup, out, progress=rec)
    side, events = res.sidecar, rec.events
    assert out.is_file() and out.with_suffix(".ckpt").is_file()
    beside = (".safetensors", ".json", ".curve.png", ".ckpt")
    assert res.files == [out, *(out.with_suffix(x) for x in beside)]
    assert all(f.is_file() for f in res.files) and len(res.curve) == 2
    assert res.heldout == side["heldout"] and rec.advances == rec.total == 4  # one per episode
    doc = json.loads(out.with_suffix(".json").read_text())
    assert doc == json.loads(json.dumps(side))
    for key in ("obs_version", "n_actions", "hidden_size", "alpha", "seed", "episodes", "command"):
        assert key in doc
    assert doc["n_actions"] == 4 and doc["hidden_size"] == 64 and doc["episodes"] == 4
    assert len(doc["data"]["sha256"]) == 64 and doc["data"]["heldout_days"]
    assert set(doc["heldout"]["methods"]) == {"marops", "random", "greedy", "myopic", "global"}
    kinds = [e["kind"] for e in events]
    assert kinds[0] == "start" and kinds.count("update") == 2 and "eval" in kinds
    # The held-out evaluations carry the daily combined cost (docs/method.md §8).
    cost = doc["heldout"]["methods"]["marops"]["daily_combined_cost"]
    assert doc["evaluations"][-1]["marops"] == cost and '"combined_cost"' not in json.dumps(doc)
    # A checkpoint that still calls it combined_cost resumes to the same sidecar.
    ckpt = out.with_suffix(".ckpt")
    state = torch.load(ckpt, weights_only=True)
    old = json.loads(json.dumps(state["evals"]).replace("daily_combined_cost", "combined_cost"))
    state["evals"] = old
    state["best"]["combined_cost"] = state["best"].pop("daily_combined_cost")
    torch.save(state, ckpt)
    assert train(tiny_csv, small_cfg, quick(), out, command="marops x") == side


def test_same_seed_same_weights(tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path) -> None:
    a, b, c = tmp_path / "a.pt", tmp_path / "b.pt", tmp_path / "c.pt"
    train(tiny_csv, small_cfg, quick(episodes=2, eval_every=100), a, resume=False)
    train(tiny_csv, small_cfg, quick(episodes=2, eval_every=100), b, resume=False)
    train(tiny_csv, small_cfg, quick(episodes=2, eval_every=100, seed=1), c, resume=False)
    assert _same(_weights(a), _weights(b))
    assert not _same(_weights(a), _weights(c))


def test_resume_matches_an_uninterrupted_run(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    whole, cut = tmp_path / "whole.pt", tmp_path / "cut.pt"
    train(tiny_csv, small_cfg, quick(), whole, resume=False)

    with pytest.raises(KeyboardInterrupt):  # the run dies before its second checkpoint
        train(tiny_csv, small_cfg, quick(), cut, resume=False, progress=Events(stop_at=4))
    assert cut.with_suffix(".ckpt").is_file() and not cut.is_file()
    rec = Events()
    train(tiny_csv, small_cfg, quick(), cut, resume=True, progress=rec)
    assert rec.events[0]["resumed"] and rec.events[0]["episode"] == 2
    assert rec.total == rec.advances == 2  # the episodes left
    assert _same(_weights(whole), _weights(cut))


def test_a_checkpoint_edited_at_a_nested_key_names_it(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    """A checkpoint of this run (its fingerprint) whose learning curve or evaluation holds
    something other than a number is refused in one line naming the key, before any
    weights are loaded."""
    import copy

    from marops_cli.errors import InputError
    from marops_cli.rl.data import fingerprint, load_training_data
    from marops_cli.rl.train import Trainer

    td = load_training_data(tiny_csv, small_cfg, quick())
    trainer = Trainer(td, tmp_path / "a.pt")
    before = copy.deepcopy(trainer.actor.state_dict())
    curve = {"episode": 2, "reward": -0.9, "delay_h": 1.0, "energy_kj": 3.0, "pg_loss": 0.1}
    costs = {"daily_combined_cost": 0.7, "avg_delay_h": 0.8}
    evaluation = {"episode": 2, "days": ["2022-08-03"], "methods": {"marops": costs}}
    state = {
        "format": "marops-train-ckpt/1",
        "fingerprint": fingerprint(td),
        **{"episode": 2, "update": 1, "elapsed_s": 1.0},
        **{"actor": {}, "critic": {}, "optimizer": {}},
        **{"history": [curve, dict(curve)], "evals": [evaluation], "baselines": [], "best": None},
    }
    edits = {
        "history[1].reward: expected a number, got '-0.9'": lambda s: s["history"][1].update(
            reward="-0.9"
        ),
        "evals[0].methods.marops.daily_combined_cost: expected a number, got nan": lambda s: s[
            "evals"
        ][0]["methods"]["marops"].update(daily_combined_cost=float("nan")),
        "history[0].pg_loss: expected a number, got True": lambda s: s["history"][0].update(
            pg_loss=True
        ),
    }
    for needle, edit in edits.items():
        edited = copy.deepcopy(state)
        edit(edited)
        torch.save(edited, trainer.ckpt)
        with pytest.raises(InputError) as err:
            trainer.load_checkpoint()
        assert str(err.value) == (
            f"{trainer.ckpt}: not a training checkpoint of this run ({needle}); pass --no-resume"
        )
        assert _same(trainer.actor.state_dict(), before) and trainer.episode == 0


def test_workers_do_not_change_the_result(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    one, two = tmp_path / "one.pt", tmp_path / "two.pt"
    train(tiny_csv, small_cfg, quick(episodes=2, eval_every=100), one, resume=False)
    train(tiny_csv, small_cfg, quick(episodes=2, eval_every=100, workers=2), two, resume=False)
    assert _same(_weights(one), _weights(two))


def test_mappo_trains_and_exports_plan_slots(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    out = tmp_path / "m.pt"
    side = train(tiny_csv, small_cfg, quick(method="mappo", episodes=2), out)
    assert side["plan_slots"] == 4 and side["n_logits"] == 16 and side["n_actions"] == 4
    assert "mappo" in side["heldout"]["methods"]


def test_several_cities_area_counts_and_fleets(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    """Every (file, areas, fleet) is a scenario; an update flies one; deterministic."""
    from marops_cli.data.synth import SynthConfig, generate, write

    river = write(
        generate(SynthConfig(days=3, seed=6, orders_per_day=500, shape="river")),
        tmp_path / "river.csv",
    )
    tc = quick(episodes=6, eval_every=100, eval_days_per_scenario=1)
    side = train(
        [tiny_csv, river], small_cfg, tc, tmp_path / "a.pt", n_depots=[6, 8], drones=[3, 4],
    )  # fmt: skip
    names = [s["name"] for s in side["scenarios"]]
    assert len(names) == 8 and len(set(names)) == 8
    assert {(s["n_depots"], s["drones"]) for s in side["scenarios"]} == {
        (6, 3), (6, 4), (8, 3), (8, 4)
    }  # fmt: skip
    assert [f["file"] for f in side["files"]] == [tiny_csv.name, "river.csv"]
    # One held-out day per scenario, each method: the rows name their scenario.
    days = side["heldout"]["days"]
    assert len(days) == 8 and all(d.split(":")[0] in (tiny_csv.name, "river.csv") for d in days)
    again = tmp_path / "b.pt"
    train(
        [tiny_csv, river], small_cfg, quick(episodes=6, eval_every=100, eval_days_per_scenario=1,
        workers=2), again, n_depots=[6, 8], drones=[3, 4],
    )  # fmt: skip
    assert _same(_weights(tmp_path / "a.pt"), _weights(again))


def test_observation_version_5_trains_and_loads(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    """--obs-version 5 writes a version-5 actor whose width is version 4's plus the three
    capability inputs, and the shipped loader flies it."""
    from marops_cli.policies.observation import obs_dim
    from marops_cli.policies.torchscript import TorchScriptPolicy

    out = tmp_path / "v5.pt"
    side = train(tiny_csv, small_cfg, quick(episodes=2, eval_every=100, obs_version=5), out)
    assert side["obs_version"] == 5
    assert side["obs_dim"] == obs_dim(side["n_actions"], 5) == obs_dim(side["n_actions"], 4) + 3
    pol = TorchScriptPolicy(out)
    assert int(pol.obs_version) == 5
