"""The landing rules backlog, rebalance, flow and battery on views small enough to check
by hand."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from marops_cli.config import PlannerConfig, override
from marops_cli.data.frame import Frame
from marops_cli.methods import METHODS
from marops_cli.plans.ranges import range_table
from marops_cli.plans.view import EVERY_DEPOT
from marops_cli.policies import (
    BacklogPolicy,
    BatteryPolicy,
    FlowPolicy,
    RebalancePolicy,
    WindowView,
    make_policy,
)
from marops_cli.segment.depots import Depots, nearest_candidates

FRAME = Frame(121.47, 31.23, 10.0)
FAR = 50_000.0
"""A depot this far (metres) is out of an empty drone's reach (about 10 km by default)."""


def _view(
    depot_x: list[float],
    stock: list[int],
    drones: list[int],
    delays: list[float] | None = None,
    arrivals: dict[int, float] | None = None,
    ready: list[bool] | None = None,
    spares: list[int] | None = None,
    n_actions: int | None = None,
) -> WindowView:
    """Depots on a line at ``depot_x`` metres; a pending parcel stocked at each depot of
    ``stock`` (delay 0 h unless ``delays``); ``arrivals``: depot -> requests expected in
    the next window (t + 1) of the history profile; ``spares``: charged spare batteries
    per depot (None: unlimited swaps); ``n_actions``: each depot's moves, itself and its
    nearest others (None: every depot)."""
    xy = np.array([[x, 0.0] for x in depot_x])
    n, n_w, t = len(depot_x), 16, 4
    prof = np.zeros((n, n_w))
    for d, k in (arrivals or {}).items():
        prof[d, t + 1] = k
    cand = nearest_candidates(xy, n if n_actions is None else n_actions)
    dep = Depots("kmeans", FRAME, xy, np.zeros(n, np.int64), cand, prof)
    p = len(stock)
    where = np.array(stock, dtype=np.int64)
    return WindowView.paper(
        t=t,
        n_windows=n_w,
        window_h=0.5,
        depots=dep,
        ranges=range_table(dep, 0.34),
        drone_depot=np.array(drones, dtype=np.int64),
        pending_idx=np.arange(p),
        pending_xy=xy[where] + [0.0, 100.0] if p else np.zeros((0, 2)),
        pending_area=where,
        pending_delay_h=np.array(delays if delays is not None else [0.0] * p, dtype=float),
        pending_due_w=np.full(p, 8),
        pending_due_s=np.full(p, 4 * 3600.0),
        pending_weight=np.full(p, 0.5),
        pending_stock=where,
        drone_ready=None if ready is None else np.array(ready),
        depot_spares=None if spares is None else np.array(spares, dtype=np.int64),
    )


def _landings(view: WindowView, actions: np.ndarray) -> list[int]:
    """Each drone's destination depot."""
    cand = view.depots.candidates
    return [int(cand[s, a]) for s, a in zip(view.drone_depot, actions, strict=True)]


def test_backlog_spreads_two_drones_over_two_equal_depots() -> None:
    # One parcel (delay 0) at each of two depots 2 km apart; both drones at depot 0.
    view = _view([0.0, 2000.0], stock=[0, 1], drones=[0, 0])
    # Drone 0: value 1 / (1 + drone 1) at home against 1 / 1 at depot 1 -> depot 1;
    # drone 1: 1 / 1 at home against 1 / (1 + drone 0) at depot 1 -> stays.
    assert _landings(view, BacklogPolicy().act(view)) == [1, 0]


def test_backlog_picks_the_depot_with_more_waiting_value() -> None:
    # Depot 0: one parcel 1 h late (value 2); depot 1: two on time (value 2, one drone
    # there); depot 2: one 2 h late (value 3).
    view = _view(
        [0.0, 2000.0, 4000.0], stock=[0, 1, 1, 2], drones=[0, 1], delays=[1.0, 0.0, 0.0, 2.0]
    )
    # Drone 0 at 0: 2 / 1, 2 / 2, 3 / 1 -> depot 2; drone 1 at 1: 2 / 1, 2 / 1, 3 / 2 ->
    # depots 0 and 1 tie at 2: the lower action index (its own depot, action 0).
    assert _landings(view, BacklogPolicy().act(view)) == [2, 1]


def test_parcels_no_drone_can_serve_wait_nowhere() -> None:
    """A parcel out of every drone's reach (or too heavy) is no value waiting at its
    depot: backlog does not fly a drone there to fetch what it cannot carry."""
    view = _view([0.0, 2000.0], stock=[1, 1], drones=[0])
    assert _landings(view, BacklogPolicy().act(view)) == [1]
    view.pending_servable = np.array([False, False])
    assert _landings(view, BacklogPolicy().act(view)) == [0]
    view.pending_servable = np.array([False, True])
    assert _landings(view, BacklogPolicy().act(view)) == [1]


def test_backlog_uses_the_service_area_when_every_parcel_is_everywhere() -> None:
    view = _view([0.0, 2000.0], stock=[1, 1], drones=[0])
    # stock = "any": the parcels count in their area (depot 1)
    view.pending_stock = np.full(2, EVERY_DEPOT)
    assert _landings(view, BacklogPolicy().act(view)) == [1]


def test_rebalance_sends_drones_where_the_demand_is() -> None:
    # No parcel waits; the history expects 4 requests at depot 2 next window.
    view = _view([0.0, 2000.0, 4000.0], stock=[], drones=[0, 0], arrivals={2: 4.0})
    assert _landings(view, RebalancePolicy().act(view)) == [2, 2]
    # Demand split between depot 1 (a waiting parcel) and depot 2 (one expected): one each.
    view = _view([0.0, 2000.0, 4000.0], stock=[1], drones=[0, 0], arrivals={2: 1.0})
    assert sorted(_landings(view, RebalancePolicy().act(view))) == [1, 2]


def test_rebalance_without_demand_stays() -> None:
    view = _view([0.0, 2000.0], stock=[], drones=[0, 1])
    assert RebalancePolicy().act(view).tolist() == [0, 0]


def test_no_rule_flies_to_an_unreachable_depot() -> None:
    # Depot 2 is 50 km away: all the waiting value and half the demand is there.
    x = [0.0, 2000.0, FAR]
    backlog = _view(x, stock=[2, 2], drones=[0, 1], delays=[3.0, 3.0])
    assert _landings(backlog, BacklogPolicy().act(backlog)) == [0, 1]
    view = _view(x, stock=[1, 2], drones=[0, 0])
    # Slots at depots 1 and 2: one drone fills depot 1's, the other cannot reach 2 and stays.
    assert sorted(_landings(view, RebalancePolicy().act(view))) == [0, 1]
    assert sorted(_landings(view, FlowPolicy().act(view))) == [0, 1]
    assert _landings(backlog, BatteryPolicy().act(backlog)) == [0, 1]


def test_a_drone_that_cannot_fly_stays() -> None:
    view = _view([0.0, 2000.0], stock=[1, 1], drones=[0, 0], ready=[False, True])
    assert _landings(view, BacklogPolicy().act(view)) == [0, 1]
    assert _landings(view, RebalancePolicy().act(view)) == [0, 1]
    assert _landings(view, FlowPolicy().act(view)) == [0, 1]
    assert _landings(view, BatteryPolicy().act(view)) == [0, 1]


def test_battery_never_lands_a_drone_where_no_spare_waits() -> None:
    # Depot 1: a parcel 2 h late (value 3); depot 2: one 1 h late (value 2); one drone at 0.
    def view(spares: list[int] | None) -> WindowView:
        return _view([0.0, 2000.0, 4000.0], [1, 2], [0], delays=[2.0, 1.0], spares=spares)

    assert _landings(view([2, 0, 1]), BacklogPolicy().act(view([2, 0, 1]))) == [1]
    # Its battery goes on charge where it lands: depot 1 has no spare for it, depot 2 has.
    assert _landings(view([2, 0, 1]), BatteryPolicy().act(view([2, 0, 1]))) == [2]
    assert _landings(view([2, 0, 0]), BatteryPolicy().act(view([2, 0, 0]))) == [0]
    # Unlimited swaps strand no drone: backlog's choice.
    assert _landings(view(None), BatteryPolicy().act(view(None))) == [1]


def test_battery_leaves_each_drone_there_its_spare() -> None:
    # Two parcels 1 h late at depot 1 (value 4), which holds one spare; two drones at 0.
    view = _view([0.0, 2000.0], stock=[1, 1], drones=[0, 0], delays=[1.0, 1.0], spares=[2, 1])
    # backlog: drone 0 takes 4 / 1, then drone 1 4 / 2 against 0 at home.
    assert _landings(view, BacklogPolicy().act(view)) == [1, 1]
    # The first takes depot 1's spare: the second would wait there, so it stays.
    assert _landings(view, BatteryPolicy().act(view)) == [1, 0]
    # A drone at depot 1 already counts on its spare: none is left for a newcomer.
    view = _view([0.0, 2000.0], stock=[1, 1], drones=[0, 1], delays=[1.0, 1.0], spares=[2, 1])
    assert _landings(view, BatteryPolicy().act(view)) == [0, 1]


def test_flow_sends_the_drones_to_the_work() -> None:
    # No work at depot 0 where both drones are; a parcel at depot 1 (2 km) and one at 2 (4 km).
    view = _view([0.0, 2000.0, 4000.0], stock=[1, 2], drones=[0, 0])
    # A drone carries 2.5 kg / 0.5 kg = 5 parcels a window, so one drone takes all of a
    # depot's: one to each.
    assert sorted(_landings(view, FlowPolicy().act(view))) == [1, 2]
    # Expected requests are work too: 12 at depot 2 next window fill two drones' shares.
    view = _view([0.0, 2000.0, 4000.0], stock=[], drones=[0, 0], arrivals={2: 12.0})
    assert _landings(view, FlowPolicy().act(view)) == [2, 2]


def test_flow_flies_only_where_the_work_pays_the_flight() -> None:
    view = _view([0.0, 2000.0], stock=[1], drones=[0])
    assert _landings(view, FlowPolicy().act(view)) == [1]
    # At α 0.999 a parcel-hour is worth 1/999 of a usable battery (169 J), far less than
    # the 2 km flight (32 kJ): the drone stays.
    flow = FlowPolicy()
    flow.configure(override(PlannerConfig(), plan__alpha=0.999))
    assert _landings(view, flow.act(view)) == [0]


def test_flow_never_strands_a_drone() -> None:
    # Three parcels at depot 1, one at depot 2; one drone at 0.
    def view(spares: list[int]) -> WindowView:
        return _view([0.0, 2000.0, 4000.0], [1, 1, 1, 2], [0], spares=spares)

    assert _landings(view([2, 2, 2]), FlowPolicy().act(view([2, 2, 2]))) == [1]
    assert _landings(view([2, 0, 2]), FlowPolicy().act(view([2, 0, 2]))) == [2]
    assert _landings(view([2, 0, 0]), FlowPolicy().act(view([2, 0, 0]))) == [0]


def test_flow_keeps_as_many_drones_at_a_depot_as_its_chargers_keep_flying() -> None:
    # Twenty parcels at depot 1: two drones' shares (5 a window over 2 windows each).
    view = _view([0.0, 2000.0], stock=[1] * 20, drones=[0, 0])
    assert _landings(view, FlowPolicy().act(view)) == [1, 1]
    # One 62.5 W charger restores 2/3 of a usable battery a window: one drone flies there.
    view.depot_spares = np.array([2, 2])
    assert sorted(_landings(view, FlowPolicy().act(view))) == [0, 1]
    two = FlowPolicy()
    two.configure(override(PlannerConfig(), ops__chargers_per_depot=2, ops__charge_power_w=125.0))
    assert _landings(view, two.act(view)) == [1, 1]
    # Neither work nor battery left for a second drone: no share, however the two combine.
    view = _view([0.0, 2000.0], stock=[1], drones=[0, 0], spares=[2, 2])
    assert sorted(_landings(view, FlowPolicy().act(view))) == [0, 1]


def test_flow_counts_the_drones_that_cannot_fly_where_they_are() -> None:
    # One parcel at depot 1, where a drone waits for a battery: it holds the one share.
    view = _view([0.0, 2000.0], stock=[1], drones=[0, 1], ready=[True, False])
    assert _landings(view, FlowPolicy().act(view)) == [0, 1]
    view.drone_ready = np.ones(2, bool)
    assert _landings(view, FlowPolicy().act(view)) == [0, 1]  # drone 1 is there already
    view.drone_depot = np.array([0, 0])
    assert sorted(_landings(view, FlowPolicy().act(view))) == [0, 1]


def test_flow_breaks_ties_by_depot_id() -> None:
    # Equal parcels at depots 1 and 2, each 2 km from the one drone at depot 0, on either
    # side: depot 1 whichever side it is on.
    for x in ([0.0, -2000.0, 2000.0], [0.0, 2000.0, -2000.0]):
        view = _view(x, stock=[1, 2], drones=[0], spares=[2, 2, 2])
        view.depots.arrivals = None
        assert _landings(view, FlowPolicy().act(view)) == [1]


@pytest.mark.parametrize("name", ["backlog", "rebalance", "flow", "battery"])
def test_the_rules_are_deterministic(name: str) -> None:
    view = _view(
        [0.0, 2000.0, 4000.0, 6000.0],
        stock=[0, 1, 1, 2, 3, 3, 3],
        drones=[0, 0, 1, 2, 3, 3],
        delays=[0.5, 1.0, 0.0, 2.0, 0.0, 0.2, 0.1],
        arrivals={0: 2.0, 2: 3.0},
        spares=[1, 2, 0, 1],
    )
    first = make_policy(name).act(view)
    assert all(np.array_equal(first, make_policy(name, seed=s).act(view)) for s in range(3))
    assert METHODS[name] == ("kmeans", name)


@pytest.mark.parametrize("name", ["backlog", "rebalance", "flow", "battery"])
def test_replay_day_flies_a_rule_under_the_operating_model(
    tmp_path: Path, example_csv: Path, name: str
) -> None:
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    config = Path(__file__).parents[2] / "examples" / "operations.toml"
    args = ["replay-day", str(example_csv), "--date", "0811", "--method", name]
    res = CliRunner().invoke(app, [*args, "--config", str(config), "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    record = json.loads(next(tmp_path.rglob("metrics.json")).read_text(encoding="utf-8"))
    day = record["days"][0]
    assert day["delivered"] > 0 and record["meta"]["config"]["ops"]["stock"] == "home"
