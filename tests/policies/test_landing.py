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
from marops_cli.config import OpsConfig, PlannerConfig, override
from marops_cli.errors import InputError
from marops_cli.plans.view import FREE
from marops_cli.policies import BacklogPolicy, FlowPolicy, make_policy
from marops_cli.policies.landing import (
    BACKLOG_WEIGHTS,
    CONTEXT_FEATURES,
    CONTEXT_START,
    FEATURES,
    FREE_FEATURES,
    JOINT_START,
    RULE_FEATURES,
    RULES_START,
    DepotState,
    LandingActor,
    extend_weights,
    landing_features,
    operating_model,
)
from marops_cli.rl.es import write_landing_actor

from .test_rules import FAR, _landings, _view

REALISTIC = "stock=home, batteries, busy"


def _side(model: str = REALISTIC, fmt: str = "/1") -> dict:
    return {"format": "marops-landing-actor" + fmt, "operating_model": model}


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


def test_context_features_by_hand() -> None:
    # The view of test_features_by_hand: 2 drones on 3 areas (density lg (1 + 2/3)),
    # 3 parcels waiting (load lg (1 + 3/2)), no charged spare at depot 0, α 0.8.
    view = _view([0.0, 1000.0, 3000.0], [1, 1, 2], [0, 1], [0.5, 1.5, 0.0], arrivals={2: 2.0})
    view = replace(view, depot_spares=np.array([0, 1, 2]), depot_charging=np.array([3, 0, 0]))
    depots = DepotState(view, alpha=0.8)
    there = np.array([0.0, 1.0, 0.0])
    basic = landing_features(view, depots, 0, there)
    f = landing_features(view, depots, 0, there, context=True)
    assert f.shape == (3, len(FEATURES) + len(CONTEXT_FEATURES))
    assert np.array_equal(f[:, : len(FEATURES)], basic)  # the first twelve unchanged
    density, load = np.log1p(2 / 3), np.log1p(3 / 2)
    # columns: density x stay, density x km, strands, load x stay, α x km, α x stay
    assert f[0, 12:] == pytest.approx([density, 0.0, 0.0, load, 0.0, 0.8], abs=1e-12)
    assert f[2, 12:] == pytest.approx([0.0, density * 3.0, 0.0, 0.0, 2.4, 0.0], abs=1e-12)
    # From depot 1, depot 0 has no charged spare: flying there strands the drone.
    f1 = landing_features(view, depots, 1, there, context=True)
    dest0 = int(np.flatnonzero(view.depots.candidates[1] == 0)[0])
    assert f1[dest0, 14] == 1.0 and f1[:, 14].sum() == 1.0


def test_context_actor_reads_alpha() -> None:
    # Weight on α x distance only: at α 0.9 the actor flies to the farthest depot it can
    # reach when the weight is positive, and stays when it is negative; the run's α comes
    # from the planner config. The one parcel waits at the drone's own depot, so the
    # flow rule, which moves the drones the actor keeps home, keeps it there too.
    view = _view([0.0, 800.0, 1600.0, FAR], [0], [0])
    w = CONTEXT_START.copy()
    w[FEATURES.index("backlog score")] = 0.0
    w[len(FEATURES) + CONTEXT_FEATURES.index("alpha x distance km")] = 1.0
    actor = LandingActor(w)
    actor.configure(override(PlannerConfig(), plan__alpha=0.9))
    assert actor.alpha == 0.9 and actor.context and actor.joint
    assert [int(view.depots.candidates[0, a]) for a in actor.act(view)] == [2]
    w[len(FEATURES) + CONTEXT_FEATURES.index("alpha x distance km")] = -1.0
    assert [int(view.depots.candidates[0, a]) for a in LandingActor(w).act(view)] == [0]


def test_flow_features_by_hand() -> None:
    # The view of test_features_by_hand; the flow rule lands 2 ready drones at depot 1
    # and none elsewhere: slots 0 and 1 of depot 1 are the flow rule's, slot 2 is not.
    view = _view([0.0, 1000.0, 3000.0], [1, 1, 2], [0, 1], [0.5, 1.5, 0.0], arrivals={2: 2.0})
    view = replace(view, depot_spares=np.array([0, 1, 2]), depot_charging=np.array([3, 0, 0]))
    depots = DepotState(view, alpha=0.8)
    there = np.array([0.0, 1.0, 0.0])
    context = landing_features(view, depots, 0, there, context=True)
    depots.flow = np.array([0.0, 2.0, 0.0])
    n = len(FEATURES) + len(CONTEXT_FEATURES)
    density, load = np.log1p(2 / 3), np.log1p(3 / 2)
    for slot, fills in ((0, 1.0), (1, 1.0), (2, 0.0)):
        f = landing_features(view, depots, 0, there, context=True, slot=slot)
        assert f.shape == (3, n + len(RULE_FEATURES))
        assert np.array_equal(f[:, :n], context)  # the first eighteen unchanged
        assert f[1, n:] == pytest.approx([fills, density * fills, load * fills], abs=1e-12)
        assert not f[[0, 2], n:].any()  # no drone of the flow rule's lands at depot 0 or 2


def _landed(view, acts) -> list[int]:  # noqa: ANN001
    cand = view.depots.candidates
    return sorted(int(cand[s, a]) for s, a in zip(view.drone_depot, acts, strict=True))


def test_an_actor_on_the_flow_features_flies_the_flow_rule_plan() -> None:
    # Weight on "flow slot" only (and a little on distance): the actor lands as many
    # drones at each depot as the flow rule does, and none free (the free landing does
    # not share the flow rule's score of staying).
    rng = np.random.default_rng(7)
    w = np.zeros(RULES_START.size)
    w[len(FEATURES) + len(CONTEXT_FEATURES) + RULE_FEATURES.index("flow slot")] = 10.0
    w[FEATURES.index("distance km")] = -0.01
    actor, flow = LandingActor(w), FlowPolicy()
    cfg = override(PlannerConfig(), plan__alpha=0.5)
    actor.configure(cfg)
    flow.configure(cfg)
    moved = 0
    for _ in range(10):
        stock = list(rng.integers(0, 6, size=12))
        drones = list(rng.integers(0, 6, size=5))
        view = _view([0.0, 400.0, 800.0, 1200.0, 1600.0, FAR], stock, drones, spares=[2] * 6)
        mine, theirs = actor.act(view), flow.act(view)
        assert FREE not in mine
        assert _landed(view, mine) == _landed(view, theirs)
        moved += int((theirs != 0).sum())
    assert moved > 0  # the flow rule moved drones: the check was not all staying


def test_extended_weights_decide_as_before() -> None:
    rng = np.random.default_rng(9)
    w3 = rng.normal(size=CONTEXT_START.size)
    w4 = extend_weights(w3, RULES_START.size)
    assert w4[:18] == pytest.approx(w3[:18]) and w4[-4:] == pytest.approx(w3[-4:])
    assert not w4[18:21].any()
    assert extend_weights(BACKLOG_WEIGHTS, JOINT_START.size) == pytest.approx(JOINT_START)
    for _ in range(5):
        view = _view([0.0, 800.0, 1600.0, 2400.0], list(rng.integers(0, 4, 8)), [0, 1, 1, 3])
        assert np.array_equal(LandingActor(w3).act(view), LandingActor(w4).act(view))
    with pytest.raises(ValueError, match="cannot extend 25 landing weights to 22"):
        extend_weights(w4, CONTEXT_START.size)
    with pytest.raises(ValueError, match="cannot extend 16 landing weights to 12"):
        extend_weights(JOINT_START, BACKLOG_WEIGHTS.size)


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


def _move_one(joint: bool) -> list[int]:
    """Depots at 0, 1 and 1.3 km, drones at the first and the last, two parcels at the
    middle one (delays 0 and 0.5 h: value 2.5); the score is the backlog score less the
    distance in km. Each drone's landing depot."""
    view = _view([0.0, 1000.0, 1300.0], [1, 1], [0, 2], [0.0, 0.5])
    w = np.zeros(len(FEATURES) + (len(FREE_FEATURES) if joint else 0))
    w[FEATURES.index("backlog score")], w[FEATURES.index("distance km")] = 1.0, -1.0
    acts = LandingActor(w).act(view)
    return [int(view.depots.candidates[s, a]) for s, a in zip(view.drone_depot, acts, strict=True)]


def test_sequential_sends_both_drones() -> None:
    # Drone 0 first: lg 2.5 − 1.0 = 0.253 > 0 (stay) -> depot 1; then drone 1:
    # lg (2.5 / 2) − 0.3 = 0.511 > 0 -> depot 1 too.
    assert _move_one(joint=False) == [1, 1]


def test_joint_sends_the_nearer_drone_only() -> None:
    # Drone 1 alone: lg 2.5 − 0.3 = 0.953; drone 0 alone: 0.253; both:
    # lg 2.5 + lg 1.25 − 1.3 = 0.764. The assignment keeps the best total.
    assert _move_one(joint=True) == [0, 1]


def test_joint_free_landing_and_held_drones() -> None:
    view = _view([0.0, 800.0, 1600.0, FAR], [1, 2], [0, 1, 2], ready=[True, False, True])
    w = JOINT_START.copy()
    w[len(FEATURES) + FREE_FEATURES.index("free")] = 5.0
    assert list(LandingActor(w).act(view)) == [FREE, 0, FREE]  # a held drone stays
    w[len(FEATURES) + FREE_FEATURES.index("free")] = -5.0
    assert FREE not in LandingActor(w).act(view)
    # With the free landing at 0 a second drone staying at an empty depot ties with its
    # first slot's score (nothing waits there): the slot wins the tie.
    two = _view([0.0, 800.0], [1], [0, 0])
    assert FREE not in LandingActor(JOINT_START).act(two)


def test_joint_reaches_only_what_it_can() -> None:
    view = _view([0.0, 800.0, FAR], [2, 2, 2], [0])
    w = JOINT_START.copy()
    w[FEATURES.index("backlog score")] = 5.0  # all the value is out of reach
    assert list(LandingActor(w).act(view)) == [0]


def test_joint_spreads_a_large_fleet() -> None:
    # 40 drones at one end of 20 depots on a line, parcels everywhere: every drone gets
    # a destination among its candidates, and no depot more drones than value per drone
    # pays for (the backlog score falls with each drone there).
    rng = np.random.default_rng(5)
    view = _view(list(np.arange(20) * 400.0), list(rng.integers(0, 20, 60)), [0] * 20 + [1] * 20)
    acts = LandingActor(JOINT_START).act(view)
    n_a = view.depots.candidates.shape[1]
    assert acts.shape == (40,) and all(a == FREE or 0 <= a < n_a for a in acts)
    landed = [
        int(view.depots.candidates[s, a])
        for s, a in zip(view.drone_depot, acts, strict=True)
        if a != FREE
    ]
    assert len(set(landed)) > 2  # spread, not all at home


def _called(stock: list[int], drones: list[int], delays: list[float]) -> list[int]:
    """Depots at 0, 1.0, 1.9 and 2.7 km, each with one move, to its nearest other
    (0 -> 1 -> 2 -> 3, and 3 -> 2): the joint actor from the backlog score, each drone's
    landing depot."""
    view = _view([0.0, 1000.0, 1900.0, 2700.0], stock, drones, delays, n_actions=2)
    assert view.depots.candidates[:, 1].tolist() == [1, 2, 3, 2]
    return _landed(view, LandingActor(JOINT_START).act(view))


def test_parcels_no_drone_comes_for_call_the_nearest_idle_one() -> None:
    """Parcels at depot 3 that have waited a window, no drone there: the drone that
    would stay at an empty depot takes the first move of its way there (depot 0 -> 1),
    although no score sees that far; the nearer of two such drones goes (2 -> 3)."""
    assert _called([3], [0], [0.5]) == [1]
    assert _called([3, 3], [0, 2], [0.5, 1.5]) == [0, 3]
    assert _called([3], [0, 1], [0.5]) == [0, 2]
    # A drone that would leave the depot where the parcels wait for an empty one stays.
    view = _view([0.0, 1000.0, 1900.0, 2700.0], [0], [0], [1.0], n_actions=2)
    w = JOINT_START.copy()
    w[FEATURES.index("stay")] = -5.0  # every drone that can fly leaves
    assert _landed(view, LandingActor(w).act(view)) == [0]


def test_no_drone_is_called_for_fresh_parcels_or_where_one_is() -> None:
    # Waited less than a window (0.5 h): the drone stays.
    assert _called([3], [0], [0.4]) == [0]
    # A drone at depot 3 already: no other is called.
    assert _called([3], [0, 3], [1.0]) == [0, 3]
    # A drone landing where parcels wait is not idle: the backlog score sends the drone
    # at depot 1 to depot 2's parcel, and nothing calls it on to depot 3.
    assert _called([2, 3], [1], [0.0, 1.0]) == [2]


def test_the_drones_the_actor_keeps_home_are_the_flow_rules_to_move() -> None:
    """Two drones at depot 0, where nothing waits; a parcel at depot 1 (2 km) and one at
    depot 2 (4 km). An actor that keeps every drone home (a large weight on staying)
    hands both to the flow rule, which sends one to each depot (as it does alone)."""
    view = _view([0.0, 2000.0, 4000.0], stock=[1, 2], drones=[0, 0])
    w = JOINT_START.copy()
    w[FEATURES.index("stay")] = 5.0
    assert _landed(view, LandingActor(w).act(view)) == [1, 2]
    assert _landed(view, FlowPolicy().act(view)) == [1, 2]


def test_the_actors_moves_stand_and_count_where_they_land() -> None:
    """Two drones at depot 0; five parcels at depot 1, one drone's share of them, and
    nothing elsewhere. The actor sends drone 0 to depot 1 and keeps drone 1 home: the
    flow rule counts drone 0 at depot 1, where no work is left for a second drone, so
    drone 1 stays; the flow rule alone sends exactly one drone there too."""
    view = _view([0.0, 2000.0, 4000.0], stock=[1] * 5, drones=[0, 0])
    w = JOINT_START.copy()
    w[FEATURES.index("backlog score")] = 0.0
    w[FEATURES.index("parcels")] = 1.0  # every slot at depot 1 scores lg 6
    w[FEATURES.index("there")] = -10.0  # a second drone there scores far less
    acts = LandingActor(w).act(view)
    cand = view.depots.candidates
    assert [int(cand[0, a]) for a in acts] == [1, 0]
    assert sorted(_landings(view, FlowPolicy().act(view))) == [0, 1]
    # Without the actor's move counted at depot 1, the flow rule would send drone 1 there.
    flow = FlowPolicy()
    assert _landings(view, flow.act(view, [1], np.array([2.0, 0.0, 0.0]))) == [0, 1]


def test_operating_model_names() -> None:
    assert operating_model(OpsConfig()) == REALISTIC
    assert operating_model(OpsConfig.paper_model()) == "paper"
    assert operating_model(OpsConfig(busy=False)) == "stock=home, batteries"


@pytest.mark.parametrize(("fmt", "size"), [("/2", 16), ("/3", 22), ("/4", 25), ("/1", 12)])
def test_file_round_trip(tmp_path: Path, fmt: str, size: int) -> None:
    w = np.linspace(-1.0, 1.0, size)
    write_landing_actor(w, tmp_path / "a.safetensors", _side(fmt=fmt))
    pol = make_policy(str(tmp_path / "a.safetensors"), model=REALISTIC)
    assert isinstance(pol, LandingActor) and pol.joint == (size != 12)
    assert pol.context == (size in (22, 25))
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
            "expected format, one of 'marops-landing-actor/2', 'marops-landing-actor/3', "
            "'marops-landing-actor/4', 'marops-landing-actor/1', got 'marops-basic'",
        ),
        (
            {"weight": np.zeros(12, np.float32)},
            {"operating_model": REALISTIC},
            "key 'format': a landing actor's sidecar needs format",
        ),
        ({"weight": np.zeros(12, np.float32)}, [REALISTIC], "expected a JSON object, got a list"),
        ({"weight": np.zeros(12, np.float32)}, _side(fmt="/2"), r"expected float32 \[16\]"),
        ({"weight": np.zeros(16, np.float32)}, _side(), r"expected float32 \[12\]"),
        ({"weight": np.zeros(16, np.float32)}, _side(fmt="/3"), r"expected float32 \[22\]"),
        ({"weight": np.zeros(22, np.float32)}, _side(fmt="/4"), r"expected float32 \[25\]"),
        (
            {"weight": np.zeros(12, np.float32)},
            {**_side(), "format": ["x"]},
            "key 'format': expected format, one of 'marops-landing-actor/2', .*, got a list",
        ),
        (
            {"weight": np.zeros(12, np.float32)},
            {"format": "marops-landing-actor/1", "operating-model": "paper"},
            "key 'operating-model': unknown key 'operating-model' \\(did you mean operating_model",
        ),
    ],
    ids=[
        "shape",
        "dtype",
        "nan",
        "extra",
        "no-model",
        "format",
        "no-format",
        "not-object",
        "joint-of-12",
        "sequential-of-16",
        "context-of-16",
        "rules-of-22",
        "format-list",
        "model-misspelt",
    ],
)
def test_bad_files(tmp_path: Path, tensors: dict, side: object, match: str) -> None:
    from safetensors.numpy import save_file

    save_file(tensors, str(tmp_path / "a.safetensors"))
    (tmp_path / "a.json").write_text(json.dumps(side))
    with pytest.raises(InputError, match=match):
        make_policy(str(tmp_path / "a.safetensors"), model=REALISTIC)


def test_a_header_giving_a_key_twice_is_refused(tmp_path: Path) -> None:
    """The weights file's JSON header gives 'weight' twice: the safetensors reader kept
    the last unsaid, where every other JSON marops reads refuses a key given twice."""
    entry = {"dtype": "F32", "shape": [12], "data_offsets": [0, 48]}
    one = json.dumps({"weight": entry})
    header = ("{" + one[1:-1] + "," + one[1:-1] + "}").encode()
    header += b" " * (-len(header) % 8)
    path = tmp_path / "a.safetensors"
    path.write_bytes(len(header).to_bytes(8, "little") + header + bytes(48))
    (tmp_path / "a.json").write_text(json.dumps(_side()))
    with pytest.raises(InputError, match="the key 'weight' appears twice in one object"):
        make_policy(str(path), model=REALISTIC)
    header = json.dumps({"weight": entry}).encode()  # the same file, the key once
    header += b" " * (-len(header) % 8)
    path.write_bytes(len(header).to_bytes(8, "little") + header + bytes(48))
    assert isinstance(make_policy(str(path), model=REALISTIC), LandingActor)


def _weights_file(path: Path, header: dict, data: bytes) -> None:
    text = json.dumps(header).encode()
    text += b" " * (-len(text) % 8)
    path.write_bytes(len(text).to_bytes(8, "little") + text + data)


def test_the_weights_header_is_parsed_once_by_marops(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The weights file is read and its JSON header parsed once, by marops (which refuses
    a key given twice), where the safetensors reader parsed it a second time; the values
    are the file's."""
    import safetensors

    def refused(*_a: object, **_k: object) -> None:
        raise AssertionError("the header was parsed a second time")

    monkeypatch.setattr(safetensors, "safe_open", refused)
    values = np.arange(12, dtype="<f4") / 10
    path = tmp_path / "a.safetensors"
    _weights_file(
        path, {"weight": {"dtype": "F32", "shape": [12], "data_offsets": [0, 48]}}, values.tobytes()
    )
    (tmp_path / "a.json").write_text(json.dumps(_side()))
    actor = make_policy(str(path), model=REALISTIC)
    assert isinstance(actor, LandingActor)
    assert actor.weight.tolist() == values.astype(np.float64).tolist()


@pytest.mark.parametrize(
    ("entry", "data"),
    [
        ({"dtype": "F32", "shape": [12], "data_offsets": [0, 48]}, bytes(40)),
        ({"dtype": "F32", "shape": [12], "data_offsets": [0, 40]}, bytes(40)),
        ({"dtype": "F32", "shape": [12], "data_offsets": [8, 56]}, bytes(56)),
        ({"dtype": "F32", "shape": [12], "data_offsets": [0, 48]}, bytes(56)),
        ({"dtype": "F32", "shape": [-12], "data_offsets": [0, 48]}, bytes(48)),
        ({"dtype": "F32", "shape": [12]}, bytes(48)),
        ({"shape": [12], "data_offsets": [0, 48]}, bytes(48)),
    ],
    ids=[
        "short-data",
        "offsets-off-shape",
        "gap",
        "data-beyond",
        "negative",
        "no-offsets",
        "no-dtype",
    ],
)
def test_a_weights_file_whose_tensors_do_not_fill_its_data_is_refused(
    tmp_path: Path, entry: dict, data: bytes
) -> None:
    """The layout the safetensors reader checked, still checked: each tensor its shape's
    bytes, one after the other, filling the data exactly."""
    path = tmp_path / "a.safetensors"
    _weights_file(path, {"weight": entry}, data)
    (tmp_path / "a.json").write_text(json.dumps(_side()))
    with pytest.raises(InputError, match="not a safetensors weights file") as err:
        make_policy(str(path), model=REALISTIC)
    assert err.value.file == str(path)
    path.write_bytes(b"\x10" + bytes(6))  # shorter than a header's length
    with pytest.raises(InputError, match="not a safetensors weights file"):
        make_policy(str(path), model=REALISTIC)


@pytest.mark.parametrize("value", [3.4e38, -3.4e38, 1.5e6])
def test_finite_weights_beyond_the_documented_range_are_refused_on_load(
    tmp_path: Path, value: float
) -> None:
    """Weights of magnitude up to float32's largest are finite, yet their scores overflow:
    refused as the actor loads, naming the file and the tensor (docs/method.md §6), not
    a failed run at its first window."""
    from safetensors.numpy import save_file

    w = np.linspace(-1.0, 1.0, 12).astype(np.float32)
    w[3] = value
    save_file({"weight": w}, str(tmp_path / "a.safetensors"))
    (tmp_path / "a.json").write_text(json.dumps(_side()))
    with pytest.raises(InputError) as err:
        make_policy(str(tmp_path / "a.safetensors"), model=REALISTIC)
    assert err.value.file == str(tmp_path / "a.safetensors") and err.value.column == "weight"
    assert "beyond the 1e+06" in err.value.message
    w[3] = 1e6  # the bound itself is a weight
    save_file({"weight": w}, str(tmp_path / "a.safetensors"))
    assert isinstance(make_policy(str(tmp_path / "a.safetensors"), model=REALISTIC), LandingActor)


def test_a_huge_operating_model_in_a_sidecar_is_quoted_in_a_short_line(tmp_path: Path) -> None:
    """A sidecar's operating model of 10 MB: the refusal quotes its start, not all of it."""
    write_landing_actor(BACKLOG_WEIGHTS, tmp_path / "a.safetensors", _side("x" * 10_000_000))
    with pytest.raises(InputError) as err:
        make_policy(str(tmp_path / "a.safetensors"), model=REALISTIC)
    line = str(err.value)
    assert "trained for the operating model 'xxxx" in line and "…" in line
    assert REALISTIC in line and len(line) < 300 + len(str(tmp_path))


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


def test_the_shipped_sidecar_beside_other_weights_is_refused(tmp_path: Path) -> None:
    """The sidecar `marops train` writes lists the weights (to 6 decimals): the shipped
    actor's loads with its own, and beside another actor's weights of the same shape it
    is refused, naming the sidecar's key."""
    from safetensors.numpy import load_file, save_file

    shipped = Path(__file__).resolve().parents[2] / "policies" / "marops-ops.safetensors"
    side = json.loads(shipped.with_suffix(".json").read_text(encoding="utf-8"))
    own = load_file(str(shipped))["weight"]
    for name, weight in (("same", own), ("other", own + np.float32(0.001))):
        save_file({"weight": weight}, str(tmp_path / f"{name}.safetensors"))
        (tmp_path / f"{name}.json").write_text(json.dumps(side), encoding="utf-8")
    actor = make_policy(str(tmp_path / "same.safetensors"), model=REALISTIC)
    assert isinstance(actor, LandingActor)
    with pytest.raises(InputError) as err:
        make_policy(str(tmp_path / "other.safetensors"), model=REALISTIC)
    assert err.value.file == str(tmp_path / "other.json") and err.value.column == "weight"
    assert "not the weights of other.safetensors" in err.value.message
