"""The operating model (docs/method.md, "Operating model"): parcels at their depot,
batteries that charge, drones that stay busy; each case small enough to check by hand."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np
import pytest

from marops_cli.config import OpsConfig, PlannerConfig, load_config
from marops_cli.data.frame import Frame
from marops_cli.data.table import DayRequests
from marops_cli.errors import InputError
from marops_cli.plans.view import EVERY_DEPOT
from marops_cli.policies.base import PolicyBase
from marops_cli.segment.depots import Depots, nearest_candidates
from marops_cli.sim.metrics import ops_metrics
from marops_cli.sim.replay import fly_day
from marops_cli.sim.state import DayState
from marops_cli.sim.step import WindowStep, fly_window, plan_step

FRAME = Frame(121.47, 31.23, 10.0)


def ops_(**changes: object) -> OpsConfig:
    """The paper's operating model with ``changes``: each test turns on what it checks."""
    return OpsConfig(**{"stock": "any", "batteries_per_depot": None, "busy": False, **changes})


def depots(*xy: tuple[float, float]) -> Depots:
    arr = np.array(xy, dtype=float)
    n = len(arr)
    return Depots("kmeans", FRAME, arr, np.ones(n, dtype=np.int64), nearest_candidates(arr, n))


def day(xy, visible, window_s: float = 1800.0, n_windows: int = 4) -> DayRequests:
    """Requests at ``xy`` (0.5 kg each), visible from ``visible``, due when visible."""
    n = len(xy)
    xy = np.asarray(xy, dtype=float)
    vis = np.asarray(visible, dtype=np.int32)
    return DayRequests(
        day=dt.date(2022, 8, 11),
        frame=FRAME,
        service_start_s=9 * 3600,
        window_s=window_s,
        n_windows=n_windows,
        order_id=np.array([f"o{i}" for i in range(n)], dtype=object),
        x_m=xy[:, 0],
        y_m=xy[:, 1],
        lng=np.zeros(n),
        lat=np.zeros(n),
        weight_kg=np.full(n, 0.5),
        visible_w=vis,
        due_w=vis.copy(),
        due_s=vis * window_s + window_s,
        accept_s=vis * window_s,
    )


class Fixed(PolicyBase):
    """Every drone takes one action, every window."""

    def __init__(self, scope: str = "global", action: int = 0) -> None:
        self.scope = scope  # type: ignore[assignment]
        self.action = action

    def act(self, view):
        return np.full(view.n_drones, self.action, dtype=np.int64)


def config(ops: OpsConfig | None = None, planner: str = "pool") -> PlannerConfig:
    """The default config with ``planner`` under ``ops`` (default: the paper's model)."""
    cfg = PlannerConfig()
    cfg.plan.planner = planner
    cfg.ops = ops_() if ops is None else ops
    return cfg


TWO = depots((0.0, 0.0), (3000.0, 0.0))  # A and B, 3 km apart
# One parcel in A's area, one in B's; one drone at A.
A_AND_B = day([(200.0, 0.0), (2800.0, 0.0)], [0, 0])


@pytest.mark.parametrize("planner", ["pool", "subsets"])
@pytest.mark.parametrize("scope", ["global", "range"])
def test_a_drone_carries_only_its_depots_stock(planner, scope):
    """Under the paper's model the drone at A serves both parcels in window 0; with
    parcels at home it may only take A's: B's stays at B."""
    policy = Fixed(scope, action=1)  # range: towards B, so B's area is in range
    paper = fly_day(A_AND_B, TWO, np.array([0]), policy, config(planner=planner), method="p")
    assert paper.state.delivered_w.tolist() == [0, 0]

    home = config(ops_(stock="home"), planner)
    res = fly_day(A_AND_B, TWO, np.array([0]), policy, home, method="h")
    assert res.state.delivered_w[0] == 0
    first = [i for r in res.plans[0].routes for i in r.stops]
    assert first == [0]  # B's parcel did not leave from A
    for p in res.plans:  # whatever it flies later leaves from the parcel's own depot
        for r in p.routes:
            assert all(res.state.area[i] == r.start for i in r.stops)
    m = ops_metrics(res.state)
    assert m["stock_left_total"] == int((res.state.delivered_w < 0).sum())
    assert m["battery_waits"] == 0 and m["busy_windows"] == 0


def test_one_window_planned_alone_keeps_parcels_at_home():
    """plan-window's path: a view built without the model still gets the stock rule."""
    state = DayState(A_AND_B, TWO, np.array([0]), 0.25)
    view = state.view(0)
    assert (view.pending_stock == EVERY_DEPOT).all() and view.drone_ready.all()
    how = WindowStep.make(config(ops_(stock="home")), scope="global")
    plan = plan_step(view, np.zeros(1, dtype=np.int64), how)
    assert [i for r in plan.routes for i in r.stops] == [0]


# One depot, one drone, the same parcel every window for three windows: every route is
# the same out-and-back, so each uses the same energy E.
ONE = depots((0.0, 0.0))
SAME_SPOT = day([(1500.0, 0.0)] * 3, [0, 1, 2], n_windows=6)


def test_a_drone_without_a_charged_battery_waits_until_one_is():
    """1 spare battery, 1 charger charging E / 2.5 per window: a battery used in window 0
    charges in windows 1, 2, 3 and is a spare from window 4. The drone flies on its own
    battery in window 0, on the spare in window 1, waits windows 2 and 3, flies in 4."""
    paper = fly_day(SAME_SPOT, ONE, np.array([0]), Fixed(), config(), method="p")
    energies = {round(r.energy_j, 6) for p in paper.plans for r in p.routes if r.stops}
    assert paper.state.delivered_w.tolist() == [0, 1, 2] and len(energies) == 1
    e = energies.pop()
    power = e / 2.5 / SAME_SPOT.window_s
    ops = ops_(batteries_per_depot=1, chargers_per_depot=1, charge_power_w=power)
    res = fly_day(SAME_SPOT, ONE, np.array([0]), Fixed(), config(ops), method="b")
    assert res.state.delivered_w.tolist() == [0, 1, 4]
    assert [bool(r.stops) for p in res.plans for r in p.routes] == [1, 1, 0, 0, 1, 0]
    m = ops_metrics(res.state)
    # windows 2, 3 waiting; then window 5: the battery used in window 1 charges in 4..6
    assert m["battery_waits"] == 3
    assert m["charged_min"] == 0 and m["busy_windows"] == 0
    assert m["stock_left"] == {"0": 0}


def test_two_chargers_charge_two_batteries_at_once():
    """The same day with power E / 1.5 per window and two chargers: a used battery is
    a spare two windows after the window it was used in; with one spare the drone waits
    window 2 only."""
    paper = fly_day(SAME_SPOT, ONE, np.array([0]), Fixed(), config(), method="p")
    e = next(r.energy_j for r in paper.plans[0].routes)
    ops = ops_(
        batteries_per_depot=1, chargers_per_depot=2, charge_power_w=e / 1.5 / SAME_SPOT.window_s
    )
    res = fly_day(SAME_SPOT, ONE, np.array([0]), Fixed(), config(ops), method="b")
    assert res.state.delivered_w.tolist() == [0, 1, 3]


def test_a_long_flight_keeps_its_drone_out_of_the_next_window():
    """10-minute windows, a parcel 4 km out: 8 km at 10 m/s is 800 s, two windows. The
    second parcel, there from window 1, waits for the drone until window 2."""
    far = day([(4000.0, 0.0), (4000.0, 10.0)], [0, 1], window_s=600.0, n_windows=4)
    cfg = config()
    assert cfg.energy.speed_ms == 10.0
    paper = fly_day(far, ONE, np.array([0]), Fixed(), cfg, method="p")
    assert paper.state.delivered_w.tolist() == [0, 1]  # every flight ends in its window

    res = fly_day(far, ONE, np.array([0]), Fixed(), config(ops_(busy=True)), method="b")
    assert res.state.delivered_w.tolist() == [0, 2]
    assert res.state.arrive_s[0] == pytest.approx(400.0)  # 4 km out, in window 0
    assert not res.plans[1].routes[0].stops  # window 1: only its empty plan
    # out in windows 1 and 3: the second flight, from window 2, is as long
    assert ops_metrics(res.state)["busy_windows"] == 2


def test_a_busy_drone_is_not_ready_in_the_view():
    far = day([(4000.0, 0.0)], [0], window_s=600.0, n_windows=3)
    how = WindowStep.make(config(ops_(busy=True)), scope="global")
    state = DayState(far, ONE, np.array([0]), 0.25, ops=how.ops)
    assert state.view(0).drone_ready.tolist() == [True]
    fly_window(state, 0, np.zeros(1, dtype=np.int64), how)
    assert state.view(1).drone_ready.tolist() == [False]
    assert state.view(2).drone_ready.tolist() == [True]


def test_the_paper_model_tracks_nothing():
    """The defaults, and any setting that leaves all three rules off, run the paper's
    model: no operating state, views and records as before."""
    assert ops_().paper and ops_(chargers_per_depot=4, charge_power_w=9.0).paper
    assert not OpsConfig().paper  # the realistic model is the default
    state = DayState(A_AND_B, TWO, np.array([0]), 0.25, ops=ops_(chargers_per_depot=3))
    assert state.ops is None and ops_metrics(state) == {}
    view = state.view(0)
    assert (view.pending_stock == EVERY_DEPOT).all() and view.drone_ready.all()
    assert view.swaps_unlimited and not view.depot_charging.any()


def test_a_day_keeps_its_model():
    state = DayState(A_AND_B, TWO, np.array([0]), 0.25, ops=ops_(busy=True))
    state.operate(ops_(busy=True))
    with pytest.raises(ValueError, match="another operating model"):
        state.operate(ops_(stock="home"))


@pytest.mark.parametrize(
    ("table", "key"),
    [
        ("batteries_per_depot = -1", "ops.batteries_per_depot"),
        ("batteries_per_depot = 2\nchargers_per_depot = 0", "ops.chargers_per_depot"),
        ('stock = "depot"', "ops.stock"),
        ("charge_power_w = 0", "ops.charge_power_w"),
        ("bsy = true", "ops.bsy"),
    ],
)
def test_bad_ops_settings_name_their_key(tmp_path: Path, table: str, key: str):
    bad = tmp_path / "bad.toml"
    bad.write_text(f"[ops]\n{table}\n", encoding="utf-8")
    with pytest.raises(InputError) as err:
        load_config(bad)
    line = str(err.value)
    assert len(line.splitlines()) == 1 and f"invalid setting {key}:" in line


def test_replay_day_with_a_bad_ops_table_exits_2(tmp_path: Path, example_csv, fails_cleanly):
    bad = tmp_path / "bad.toml"
    bad.write_text("[ops]\nbatteries_per_depot = -1\n", encoding="utf-8")
    args = ["replay-day", str(example_csv), "--date", "0811", "--config", str(bad)]
    fails_cleanly([*args, "--out", str(tmp_path / "o")], tmp_path, "ops.batteries_per_depot")


def test_the_shipped_example_turns_every_rule_on():
    cfg = load_config(Path(__file__).parents[2] / "examples" / "operations.toml")
    ops = cfg.ops
    assert ops.stock == "home" and ops.busy and not ops.paper
    assert ops.batteries_per_depot == 2 and ops.chargers_per_depot == 1
    assert cfg.energy.battery_j / ops.charge_power_w == pytest.approx(3600.0)  # full in 1 h


def test_a_state_built_without_the_model_takes_the_steps():
    """The training environment builds its state bare: its first window binds the step's
    model, so later views show it."""
    far = day([(4000.0, 0.0)], [0], window_s=600.0, n_windows=3)
    how = WindowStep.make(config(ops_(busy=True)), scope="global")
    state = DayState(far, ONE, np.array([0]), 0.25)
    fly_window(state, 0, np.zeros(1, dtype=np.int64), how)
    assert state.ops is not None and state.view(1).drone_ready.tolist() == [False]


def test_replay_day_records_what_the_model_held_back(tmp_path: Path, example_csv):
    """The shipped example binds on the example day: parcels are left at their depots,
    and the record says so; the paper's record has none of these keys."""
    import json

    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    examples = Path(__file__).parents[2] / "examples"
    days = {}
    paper, realistic = examples / "paper-ops.toml", examples / "operations.toml"
    for name, extra in (("paper", ["--config", str(paper)]), ("ops", ["--config", str(realistic)])):
        out = tmp_path / name
        args = ["replay-day", "--area", "square", str(example_csv), "--date", "0811"]
        args += ["--method", "ops-global"]
        res = CliRunner().invoke(app, [*args, *extra, "--out", str(out)])
        assert res.exit_code == 0, res.output
        record = json.loads(next(out.rglob("metrics.json")).read_text(encoding="utf-8"))
        days[name] = record["days"][0]
        assert record["meta"]["config"]["ops"]["stock"] == ("home" if name == "ops" else "any")
    assert "battery_waits" not in days["paper"] and "stock_left" not in days["paper"]
    ops = days["ops"]
    assert sum(ops["stock_left"].values()) == ops["stock_left_total"] == ops["undelivered"]
    assert ops["stock_left_total"] > days["paper"]["undelivered"]
    assert ops["charged_min"] is not None and ops["battery_waits"] >= 0


def test_the_view_marks_the_requests_no_drone_can_ever_serve():
    """A request 40 km from every depot is out of reach even alone (about 10 km of
    empty flight at the default battery): the view says so, where the state knows the
    fleet's model; without one nothing is marked."""
    from marops_cli.energy import EnergyModel

    reqs = day([(200.0, 0.0), (40_000.0, 0.0)], [0, 0])
    model = EnergyModel.of(PlannerConfig().energy)
    state = DayState(reqs, TWO, np.array([0]), 0.25, model=model)
    assert state.view(0).pending_servable.tolist() == [True, False]
    assert DayState(reqs, TWO, np.array([0]), 0.25).view(0).pending_servable is None
    typed = DayState(reqs, TWO, np.array([0]), 0.25, drone_models=[model])
    assert typed.view(0).pending_servable.tolist() == [True, False]
