"""The observation shows, for each action, the candidates the paper's planner takes."""

from __future__ import annotations

import numpy as np
import pytest

from marops_cli.config import PlanConfig
from marops_cli.data.frame import Frame
from marops_cli.energy import EnergyModel
from marops_cli.plans.candidates import by_delay, range_candidates
from marops_cli.plans.planner import SubsetsPlanner
from marops_cli.plans.problem import WindowProblem
from marops_cli.plans.ranges import pick_candidates, range_table
from marops_cli.policies import WindowView, observe
from marops_cli.policies.observation import M_HAT, PER_ACTION
from marops_cli.segment.depots import Depots, nearest_candidates


def _view(seed: int, ties: str) -> WindowView:
    """Five depots, 60 requests with few distinct delays and due times (many ties)."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, 6000, (5, 2))
    dep = Depots(
        "kmeans", Frame(121.47, 31.23, 10.0), xy, np.zeros(5, np.int64), nearest_candidates(xy, 3)
    )
    n = 60
    pxy = rng.uniform(0, 6000, (n, 2))
    return WindowView.paper(
        t=4,
        n_windows=16,
        window_h=0.5,
        depots=dep,
        ranges=range_table(dep, 0.4),
        drone_depot=np.array([0, 2, 2, 4]),
        pending_idx=np.arange(100, 100 + n),
        pending_xy=pxy,
        pending_area=dep.assign(pxy[:, 0], pxy[:, 1]),
        pending_delay_h=rng.integers(0, 3, n) * 0.5,
        pending_due_w=np.full(n, 2),
        pending_due_s=rng.integers(0, 3, n) * 1800.0,
        pending_weight=rng.uniform(0.2, 1.0, n),
        ties=ties,  # type: ignore[arg-type]
    )


@pytest.mark.parametrize("ties", ["nearest", "due"])
@pytest.mark.parametrize("seed", range(4))
def test_range_candidates_are_the_full_sort_of_the_range(seed, ties):
    """The planner's head-only sort picks what sorting the whole range would."""
    view = _view(seed, ties)
    rank = by_delay(view)
    for s in range(len(view.depots)):
        for a in range(view.depots.n_actions):
            inside = np.flatnonzero(view.ranges[s, a][view.pending_area])
            dist = np.hypot(*(view.pending_xy[inside] - view.depots.xy[s]).T)
            full = pick_candidates(
                inside,
                view.pending_delay_h[inside],
                view.pending_due_s[inside],
                dist,
                M_HAT,
                ties,  # type: ignore[arg-type]
            )
            got = range_candidates(view, rank, view.pending_area[rank], s, a, M_HAT)
            assert got.tolist() == full.tolist()


@pytest.mark.parametrize("ties", ["nearest", "due"])
@pytest.mark.parametrize("seed", range(3))
def test_observed_candidates_are_the_planners(seed, ties):
    """Features 7 and 8 of each action (docs/method.md §6) are the delay and count of the
    candidates the paper's planner (each drone its own M̂, ``top``) plans over."""
    view = _view(seed, ties)
    obs = observe(view, M_HAT)
    model = EnergyModel()
    cfg = PlanConfig(planner="subsets", candidates="top", max_parcels=M_HAT)
    planner = SubsetsPlanner(cfg)
    for a in range(view.depots.n_actions):
        acts = np.full(view.n_drones, a)
        made = planner.plans(WindowProblem.of(view, acts, model, cfg), view)
        for u, ps in enumerate(made.plan_sets):
            f = obs[u, a * PER_ACTION : (a + 1) * PER_ACTION]
            cand = ps.request_ids
            assert f[8] == np.float32(cand.size / M_HAT)
            assert f[7] == np.float32(np.log1p(view.pending_delay_h[cand].sum()))
