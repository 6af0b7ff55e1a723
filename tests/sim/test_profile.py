"""The history days' arrival profile that the actor anticipates demand from."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from marops_cli.config import PlannerConfig
from marops_cli.data.prepare import prepare_day
from marops_cli.data.reader import read_lade
from marops_cli.data.synth import SynthConfig, generate, write
from marops_cli.sim.scenario import load_scenario


def test_profile_is_the_mean_history_day_of_visible_requests(tmp_path: Path) -> None:
    path = write(generate(SynthConfig(days=4, seed=9, orders_per_day=600)), tmp_path / "d.csv")
    cfg = PlannerConfig()
    cfg.segment.n_depots = 6
    table = read_lade(path, cfg.data)
    days = table.days()
    scn = load_scenario(path, cfg, replay_days=days[3:], table=table)
    prof = scn.depots.arrivals
    assert prof is not None and prof.shape == (6, cfg.data.n_windows)
    # By hand: every history day prepared as the simulator prepares it, counted per
    # (area, visible window), averaged over the 3 history days.
    want = np.zeros((6, cfg.data.n_windows))
    for d in scn.history_days:
        req = prepare_day(table, scn.frame, d, cfg.data)
        area = scn.depots.assign(req.x_m, req.y_m)
        np.add.at(want, (area, req.visible_w), 1.0)
    np.testing.assert_allclose(prof, want / 3, rtol=0, atol=1e-12)
    assert prof.sum() > 50  # a few hundred requests a day reach the study area


def test_depots_file_gets_the_profile_of_the_non_replayed_days(tmp_path: Path) -> None:
    path = write(generate(SynthConfig(days=3, seed=9, orders_per_day=600)), tmp_path / "d.csv")
    cfg = PlannerConfig()
    cfg.segment.n_depots = 5
    scn = load_scenario(path, cfg)
    meta = {"source": "test"}
    (tmp_path / "depots.json").write_text(__import__("json").dumps(scn.depots.to_dict(meta)))
    days = scn.table.days()
    again = load_scenario(path, cfg, depots_path=tmp_path / "depots.json", replay_days=days[2:])
    assert again.depots.arrivals is not None
    assert again.depots.arrivals.shape == (5, cfg.data.n_windows)
    assert again.history_days == days[:2]


def test_no_profile_when_every_day_is_replayed(tmp_path: Path) -> None:
    """With no day besides the replayed ones, the depots fall back to those days but the
    arrival profile does not: it would show the actor the day it is judged on."""
    path = write(generate(SynthConfig(days=2, seed=9, orders_per_day=600)), tmp_path / "d.csv")
    cfg = PlannerConfig()
    cfg.segment.n_depots = 5
    table = read_lade(path, cfg.data)
    scn = load_scenario(path, cfg, replay_days=table.days(), table=table)
    assert scn.history_days == table.days() and scn.depots.arrivals is None
    one = load_scenario(path, cfg, replay_days=table.days()[1:], table=table)
    assert one.depots.arrivals is not None
