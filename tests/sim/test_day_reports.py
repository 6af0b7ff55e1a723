"""What the day reports of its mechanism (docs/outputs.md, "Day metrics"): the drones'
decisions, the parcels waiting per depot and the operations figure; on tiny days from
the operating model's tests, checkable by hand."""

from __future__ import annotations

import io

import matplotlib
import matplotlib.pyplot
import numpy as np
import pytest

from marops_cli.config import OpsConfig
from marops_cli.energy import EnergyModel
from marops_cli.plans.view import FREE
from marops_cli.sim.metrics import day_metrics
from marops_cli.sim.ops import WAITING
from marops_cli.sim.plot import plot_operations
from marops_cli.sim.replay import fly_day

from .test_ops import A_AND_B, ONE, SAME_SPOT, TWO, Fixed, config

PNG = b"\x89PNG\r\n\x1a\n"


def shares(m: dict) -> tuple[float, float, float]:
    return m["actions_stay"], m["actions_move"], m["actions_free"]


@pytest.mark.parametrize("planner", ["pool", "subsets"])
@pytest.mark.parametrize(
    ("policy", "want"),
    [
        (Fixed("range", 0), (1.0, 0.0, 0.0)),  # stay, every window
        (Fixed("range", 1), (0.0, 1.0, 0.0)),  # A <-> B, 3 km: always in reach
        (Fixed("global", 0), (0.0, 0.0, 1.0)),  # ops-global: no destination, it lands freely
    ],
)
def test_the_decisions_of_a_day_are_counted_by_kind(planner, policy, want):
    cfg = config(planner=planner)
    res = fly_day(A_AND_B, TWO, np.array([0]), policy, cfg, method="m")
    m = day_metrics(res, EnergyModel.of(cfg.energy))
    assert shares(m) == want
    assert "actions_idle" not in m  # the paper's model holds no drone back


def test_the_free_landing_counts_as_free_with_the_pool_and_as_stay_with_the_paper_planner():
    """The paper's planner has no free landing: FREE flies (and counts) as stay."""
    for planner, want in (("pool", (0.0, 0.0, 1.0)), ("subsets", (1.0, 0.0, 0.0))):
        cfg = config(planner=planner)
        res = fly_day(A_AND_B, TWO, np.array([0]), Fixed("range", FREE), cfg, method="m")
        assert shares(day_metrics(res, EnergyModel.of(cfg.energy))) == want


def test_drones_waiting_for_a_battery_decide_nothing():
    """The battery day of the operating model's tests: the drone waits windows 2, 3 and
    5 of 6, so half its drone-windows are idle; the three it could fly were all stays."""
    paper = fly_day(SAME_SPOT, ONE, np.array([0]), Fixed(), config(), method="p")
    e = next(r.energy_j for r in paper.plans[0].routes)
    ops = OpsConfig(
        batteries_per_depot=1, chargers_per_depot=1, charge_power_w=e / 2.5 / SAME_SPOT.window_s
    )
    cfg = config(ops)
    res = fly_day(SAME_SPOT, ONE, np.array([0]), Fixed("range", 0), cfg, method="b")
    assert res.state.ops is not None
    assert res.state.ops.held_w[:, 0].tolist() == [0, 0, WAITING, WAITING, 0, WAITING]
    m = day_metrics(res, EnergyModel.of(cfg.energy))
    assert shares(m) == (1.0, 0.0, 0.0)
    assert m["actions_idle"] == 0.5 and m["battery_waits"] == 3
    # One parcel a window from window 0 to 2; with the waits the third leaves in window 4.
    assert res.state.waiting_w[:, 0].tolist() == [1, 1, 1, 1, 1, 0]
    assert paper.state.waiting_w[:, 0].tolist() == [1, 1, 1, 0, 0, 0]
    assert m["waiting_max"] == 1


def test_parcels_wait_at_their_own_depot():
    """Parcels at home: the drone at A takes A's parcel; B's waits at B all day."""
    cfg = config(OpsConfig(stock="home"))
    res = fly_day(A_AND_B, TWO, np.array([0]), Fixed("global", 0), cfg, method="h")
    assert res.state.waiting_w.tolist() == [[1, 1], [0, 1], [0, 1], [0, 1]]
    assert day_metrics(res, EnergyModel.of(cfg.energy))["waiting_max"] == 1


@pytest.mark.parametrize("ops", [None, OpsConfig(batteries_per_depot=1, busy=True)])
def test_the_operations_figure_is_a_png(ops):
    res = fly_day(A_AND_B, TWO, np.array([0]), Fixed(), config(ops), method="m")
    buf = io.BytesIO()
    plot_operations(res, A_AND_B, buf)
    assert buf.getvalue()[:8] == PNG


def test_the_routes_figure_says_when_where_and_who():
    """routes.png: each panel its window's clock times, km axes, a legend of the depots
    and each drone, depots in a colour the delay scale and the drones do not use."""
    from matplotlib.colors import to_rgba

    from marops_cli.segment.plot import DEPOT_STYLE
    from marops_cli.sim.plot import DELAY_CMAP, DRONE_COLOURS, day_figure

    res = fly_day(A_AND_B, TWO, np.array([0, 1]), Fixed("range", 1), config(), method="m")
    fig = day_figure(res, A_AND_B)
    panels = [ax for ax in fig.axes if ax.get_title().startswith("window ")]
    assert len(panels) == len(res.plans)
    start = A_AND_B.window_start(0)
    assert f"{start:%H:%M}–" in panels[0].get_title()
    assert all("km" in ax.get_xlabel() for ax in panels[-1:])
    assert all("km" in ax.get_ylabel() for ax in panels[:1])
    (legend,) = fig.legends
    labels = [t.get_text() for t in legend.get_texts()]
    assert labels == ["depot", "drone 0", "drone 1"]
    depot = np.array(to_rgba(DEPOT_STYLE["c"]))
    scale = matplotlib.colormaps[DELAY_CMAP](np.linspace(0, 1, 64))
    palette = np.array([to_rgba(c) for c in DRONE_COLOURS])
    for colours in (scale, palette):  # far from every data colour (RGB distance)
        assert np.min(np.linalg.norm(colours[:, :3] - depot[:3], axis=1)) > 0.4
    matplotlib.pyplot.close(fig)
