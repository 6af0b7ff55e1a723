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
    MyopicPolicy,
    RandomPolicy,
    StayPolicy,
    WindowView,
    make_policy,
    obs_dim,
    observe,
)
from marops_cli.policies.observation import PER_ACTION_V3, VALUE, SequentialObserver
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
    return WindowView.paper(
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
    obs = observe(view)  # version 2
    assert obs.shape == (2, obs_dim(3, 2)) and obs.dtype == np.float32
    assert np.isfinite(obs).all()
    seq = SequentialObserver(view)  # version 3
    row = seq.row(0)
    assert row.shape == (obs_dim(3, 3),) == (3 * PER_ACTION_V3 + 7,) and np.isfinite(row).all()


class _TinyActor(torch.nn.Module):
    """forward(obs, hidden) -> (logits, hidden), untrained; a TorchScript file without
    weights, so it loads only as trusted."""

    def __init__(self, n_obs: int, n_actions: int, hidden: int) -> None:
        super().__init__()
        self.gru = torch.nn.GRUCell(n_obs, hidden)
        self.head = torch.nn.Linear(hidden, n_actions)

    def forward(self, obs: torch.Tensor, hidden: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        h = self.gru(obs, hidden)
        return self.head(h), h


def _export(tmp_path: Path, n_actions: int = 3, version: int = 2) -> Path:
    torch.manual_seed(0)
    actor = torch.jit.script(_TinyActor(obs_dim(n_actions, version), n_actions, 8))
    path = tmp_path / "tiny.pt"
    actor.save(str(path))
    side = {"obs_version": version, "n_actions": n_actions, "hidden_size": 8}
    path.with_suffix(".json").write_text(json.dumps(side))
    return path


def test_torchscript_actor_loads_and_acts_deterministically(tmp_path: Path) -> None:
    path = _export(tmp_path)
    view = _view([1.0, 0.5], [(4000.0, 0.0), (2000.0, 50.0)], [0, 1, 2])
    p1 = make_policy(f"torchscript:{path}", trust=True)
    p2 = TorchScriptPolicy(path, trust=True)
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
        TorchScriptPolicy(_export(tmp_path, n_actions=4), trust=True).act(view)
    with pytest.raises(InputError, match="observation version"):
        TorchScriptPolicy(_export(tmp_path, version=OBS_VERSION + 7))
    (tmp_path / "tiny.json").unlink()
    with pytest.raises(InputError, match="sidecar beside the .pt file not found"):
        TorchScriptPolicy(tmp_path / "tiny.pt")
    with pytest.raises(InputError, match="unknown policy"):
        make_policy("clever")


def test_sequential_observation_claims_what_earlier_drones_take() -> None:
    """Two drones at depot 0, one late parcel beside it: the first drone's best plan
    claims it, so the second sees nothing left to serve there (version 3)."""
    view = _view([2.0], [(100.0, 0.0)], [0, 0])
    seq = SequentialObserver(view)
    first = seq.row(0)
    stay = slice(0, PER_ACTION_V3)
    assert first[stay][1] == pytest.approx(np.log1p(1.0))  # one pending request in range
    assert first[stay][VALUE] > 0  # worth flying: λ·(1 + 2 h) exceeds its energy
    seq.commit(0, 0)
    second = seq.row(1)
    assert second[stay][1] == 0.0 and second[stay][VALUE] == 0.0  # nothing left: stay idle
    assert second[stay][VALUE + 2] == pytest.approx(np.log1p(1.0))  # one drone went there
    assert second[-2] == pytest.approx(np.log1p(1.0))  # one co-located drone before it


def test_plan_value_feature_is_the_best_plan_of_build_plans() -> None:
    """Feature VALUE of each action = max over build_plans' plans of λ Σ v − E (hand rule)."""
    from marops_cli.config import PlanConfig
    from marops_cli.energy import EnergyModel
    from marops_cli.plans.plans import Candidates, build_plans

    view = _view(
        [1.5, 0.5, 3.0, 0.0], [(900.0, 200.0), (2500.0, -300.0), (3900.0, 0.0), (50.0, 0.0)], [0]
    )
    model, plan = EnergyModel(), PlanConfig()
    seq = SequentialObserver(view, model, plan)
    row = seq.row(0)
    lam = (1 - plan.alpha) / plan.alpha * model.usable_j
    for k in range(3):
        d = int(view.depots.candidates[0, k])
        inside = np.flatnonzero(view.ranges[0, k][view.pending_area])
        own = Candidates(view.pending_xy[inside], view.pending_weight[inside], inside)
        ps = build_plans(view.depots.xy[0], view.depots.xy[d], own, model, plan)
        net = lam * (ps.members @ (1 + view.pending_delay_h[inside])) - ps.energy_j
        best = int(np.argmax(net))
        f = row[k * PER_ACTION_V3 : (k + 1) * PER_ACTION_V3]
        assert f[VALUE] == pytest.approx(net[best] / model.usable_j, rel=1e-5)
        assert f[VALUE + 1] == pytest.approx(ps.energy_j[best] / model.usable_j, rel=1e-5)


def test_myopic_takes_the_best_plan_and_spreads_drones() -> None:
    # Late parcels at depot 2 (4 km) and at depot 0; two drones at depot 0.
    view = _view([3.0, 3.0], [(4000.0, 100.0), (100.0, 0.0)], [0, 0])
    acts = MyopicPolicy().act(view)
    dest = view.depots.candidates[0, acts].tolist()
    assert dest[0] == 2  # its range 0 -> 2 holds both: one flight serves 2 x (1 + 3 h)
    assert dest[1] == 0  # nothing left for the second: flying empty only costs energy
    # With a third late parcel only reachable through depot 1's side, the second drone
    # no longer idles: it takes what the first one left.
    view = _view(
        [3.0, 3.0, 3.0, 3.0, 3.0, 3.0],
        [
            (4000.0, 100.0),
            (100.0, 0.0),
            (3900.0, 0.0),
            (3800.0, 50.0),
            (3700.0, 0.0),
            (3950.0, -50.0),
        ],
        [0, 0],
    )
    acts = MyopicPolicy().act(view)
    assert view.depots.candidates[0, acts].tolist() == [2, 2]  # 6 parcels > M̂ = 5


def test_version3_actor_chooses_drone_by_drone(tmp_path: Path) -> None:
    path = _export(tmp_path, version=3)
    view = _view([1.0, 0.5], [(4000.0, 0.0), (2000.0, 50.0)], [0, 0, 2])
    pol = make_policy(f"torchscript:{path}", trust=True)
    acts = pol.act(view)
    # The same choices by hand: observe drone by drone, arg-max of the module's logits.
    module = torch.jit.load(str(path))
    seq, h, want = SequentialObserver(view), torch.zeros(3, 8), []
    for u in range(3):
        logits, h[u : u + 1] = module(torch.from_numpy(seq.row(u)[None, :]), h[u : u + 1])
        want.append(int(logits.argmax()))
        seq.commit(u, want[-1])
    assert acts.tolist() == want


def test_mappo_flies_the_paper_planner_whatever_the_setting():
    """The MAPPO actor's plan slots rank the paper's subset plans, so it keeps that
    planner under the route pool default; flight-range policies keep the setting."""
    from marops_cli.config import PlannerConfig
    from marops_cli.policies.direct import SlotSelector
    from marops_cli.sim.scenario import method_policy
    from marops_cli.sim.step import WindowStep

    cfg = PlannerConfig()
    plan = cfg.plan
    assert plan.planner == "pool"
    mappo = WindowStep.of(method_policy("mappo", None, 0), cfg)
    assert mappo.plan.planner == "subsets" and isinstance(mappo.selector, SlotSelector)
    assert mappo.plan.model_copy(update={"planner": "pool"}) == plan
    stay = WindowStep.of(StayPolicy(), cfg)
    assert stay.plan is plan and not isinstance(stay.selector, SlotSelector)


def test_policy_specs_parse_once_into_a_record(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every way to name a policy parses to one record; what it flies follows from it."""
    from marops_cli.policies.registry import PolicySpec

    assert PolicySpec.parse("greedy") == PolicySpec("greedy")
    assert PolicySpec.parse("learned") == PolicySpec("learned")
    assert PolicySpec.parse("torchscript:a/b") == PolicySpec("torchscript", "a/b")
    assert PolicySpec.parse("./x.pt") == PolicySpec.actor("./x.pt")  # the path as given
    assert str(PolicySpec.parse("x.pt")) == "torchscript:x.pt" and str(PolicySpec("stay")) == "stay"
    assert [PolicySpec.parse(s).loads_actor for s in ("direct", "x.pt", "myopic")] == [
        True,
        True,
        False,
    ]
    with pytest.raises(InputError, match=r"^unknown policy 'clever': expected one of stay, "):
        PolicySpec.parse("clever")
    assert PolicySpec("random").shipped() == PolicySpec("random")
    monkeypatch.setenv("MAROPS_POLICY", "/elsewhere/mine.pt")
    assert PolicySpec("learned").shipped() == PolicySpec.actor("/elsewhere/mine.pt")


def test_one_method_policy_takes_evaluate_actor_overrides(tmp_path: Path) -> None:
    """``actors`` replaces a method's shipped actor by policy kind; a given spec wins."""
    from marops_cli.sim.scenario import method_policy

    mine = _export(tmp_path)
    trusted = method_policy("marops", None, 0, actors={"learned": mine}, trust=True)
    assert trusted.identity == mine
    assert method_policy("marops", None, 0, actors={"direct": mine}).identity != mine
    assert isinstance(method_policy("marops", "greedy", 0, actors={"learned": mine}), GreedyPolicy)
    with pytest.raises(InputError, match="unknown method 'nope'"):
        method_policy("nope", None, 0)
