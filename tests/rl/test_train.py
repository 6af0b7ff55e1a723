"""Training end to end in seconds: artifacts, determinism, resume, worker count."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from marops_cli.config import PlannerConfig
from marops_cli.rl.train import train

from .conftest import quick

# torch 2.13 deprecates TorchScript; docs/method.md §6 names it as the artifact format.
pytestmark = pytest.mark.filterwarnings("ignore:`torch.jit:DeprecationWarning")


def _weights(path: Path) -> dict[str, torch.Tensor]:
    return dict(torch.jit.load(str(path)).state_dict())


def _same(a: dict[str, torch.Tensor], b: dict[str, torch.Tensor]) -> bool:
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def test_smoke_writes_actor_sidecar_checkpoint(
    tiny_csv: Path, small_cfg: PlannerConfig, tmp_path: Path
) -> None:
    out = tmp_path / "a.pt"
    events: list[dict] = []
    side = train(tiny_csv, small_cfg, quick(), out, command="marops x", on_event=events.append)
    assert out.is_file() and out.with_suffix(".ckpt").is_file()
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

    def stop_after_first_checkpoint(e: dict) -> None:
        if e["kind"] == "update" and e["episode"] == 4:
            raise KeyboardInterrupt  # the run dies before its second checkpoint

    with pytest.raises(KeyboardInterrupt):
        train(tiny_csv, small_cfg, quick(), cut, resume=False, on_event=stop_after_first_checkpoint)
    assert cut.with_suffix(".ckpt").is_file() and not cut.is_file()
    events: list[dict] = []
    train(tiny_csv, small_cfg, quick(), cut, resume=True, on_event=events.append)
    assert events[0]["resumed"] and events[0]["episode"] == 2
    assert _same(_weights(whole), _weights(cut))


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
    events: list[dict] = []
    side = train(
        [tiny_csv, river], small_cfg, tc, tmp_path / "a.pt",
        n_depots=[6, 8], drones=[3, 4], on_event=events.append,
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
