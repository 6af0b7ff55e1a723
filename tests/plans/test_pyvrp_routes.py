"""PyVRP as a route generator: its model of a window and its routes in the pool."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from marops_cli.config import PlanConfig
from marops_cli.data.frame import Frame
from marops_cli.energy import EnergyModel
from marops_cli.plans import MilpSelector
from marops_cli.plans.objective import lam_j, score_routes
from marops_cli.plans.pool import finish_route
from marops_cli.plans.problem import DroneTask, WindowProblem
from marops_cli.plans.ranges import range_table
from marops_cli.plans.window import plan_routes
from marops_cli.policies.base import WindowView
from marops_cli.segment.depots import Depots, nearest_candidates

pytest.importorskip("pyvrp")  # the pyvrp extra, installed with the test extra

from marops_cli.plans.pyvrp_routes import solve_window  # noqa: E402


def _solve(
    view: WindowView,
    lam: float,
    model: EnergyModel,
    allowed: np.ndarray | None = None,
    **kw: Any,
) -> Any:
    """PyVRP's plan of ``view``'s window, every drone landing nearest its last stop
    (``allowed``: the ``(U, R)`` requests each drone may serve; ``kw``: limits, seed)."""
    every = np.arange(view.pending_idx.size, dtype=np.int64)
    tasks = [
        DroneTask(int(s), -1, every if allowed is None else every[allowed[u]], model)
        for u, s in enumerate(view.drone_depot)
    ]
    problem = WindowProblem.of_requests(
        view.depots.xy, view.pending_xy, view.pending_weight, view.pending_delay_h, lam, tasks
    )
    return solve_window(problem, **kw)


def _view(seed: int = 3, n: int = 30) -> WindowView:
    rng = np.random.default_rng(seed)
    dep_xy = np.array([[0.0, 0.0], [3000.0, 0.0], [0.0, 3000.0], [3000.0, 3000.0]])
    depots = Depots(
        "kmeans",
        Frame(121.47, 31.23, 10.0),
        dep_xy,
        np.ones(4, np.int64),
        nearest_candidates(dep_xy, 2),
    )
    xy = rng.uniform(-500, 3500, (n, 2))
    due = rng.integers(0, 6, n)
    return WindowView.paper(
        t=5,
        n_windows=16,
        window_h=0.5,
        depots=depots,
        ranges=range_table(depots, 0.5),
        drone_depot=np.array([0, 0, 3]),
        pending_idx=np.arange(100, 100 + n),
        pending_xy=xy,
        pending_area=depots.assign(xy[:, 0], xy[:, 1]),
        pending_delay_h=np.maximum(0, 5 - due) * 0.5,
        pending_due_w=due,
        pending_due_s=due * 1800.0,
        pending_weight=rng.uniform(0.1, 1.2, n),
    )


def test_pyvrp_routes_are_feasible_under_the_exact_energy() -> None:
    """The conservative battery bound: every route PyVRP returns, flown in its own order
    and landing nearest its last customer, fits payload and battery exactly."""
    model = EnergyModel()
    view = _view()
    lam = lam_j(0.5, model.usable_j)
    peer = _solve(view, lam, model, time_limit_s=0.2)
    assert peer.stops, "PyVRP served nothing"
    seen: set[int] = set()
    for s, stops in zip(peer.start, peer.stops, strict=True):
        assert not seen & set(stops.tolist())
        seen |= set(stops.tolist())
        w = view.pending_weight[stops]
        assert w.sum() <= model.max_payload_kg + 1e-9
        last = view.pending_xy[stops[-1]]
        end = int(np.hypot(*(view.depots.xy - last).T).argmin())
        pts = np.vstack([view.depots.xy[s], view.pending_xy[stops], view.depots.xy[end]])
        energy = model.route_energy(pts, w)[1].sum()
        assert energy <= model.usable_j
        # re-ordering for energy never costs more than PyVRP's own order
        order, end2 = finish_route(
            view.depots.xy[s], None, view.depots.xy, view.pending_xy[stops], w, model
        )
        st = stops[order]
        pts2 = np.vstack([view.depots.xy[s], view.pending_xy[st], view.depots.xy[end2]])
        assert model.route_energy(pts2, view.pending_weight[st])[1].sum() <= energy + 1e-6


def test_pool_with_pyvrp_columns_is_at_least_as_good_as_pyvrp() -> None:
    """PyVRP's routes join the pool as columns, so the selection is worth at least
    PyVRP's own plan (flown in its order, landing nearest), and the same run twice gives
    the same routes (PyVRP stops after a number of iterations, not seconds)."""
    model = EnergyModel()
    view = _view(seed=8, n=40)
    lam = lam_j(0.5, model.usable_j)
    peer = _solve(view, lam, model, iterations=200, seed=view.t)
    energy = 0.0
    for s, stops in zip(peer.start, peer.stops, strict=True):
        last = view.pending_xy[stops[-1]]
        end = int(np.hypot(*(view.depots.xy - last).T).argmin())
        pts = np.vstack([view.depots.xy[s], view.pending_xy[stops], view.depots.xy[end]])
        energy += model.route_energy(pts, view.pending_weight[stops])[1].sum()
    served = np.concatenate(peer.stops)
    g_peer = lam * (1.0 + view.pending_delay_h[served]).sum() - energy

    cfg = PlanConfig(pyvrp_iterations=200, pool_iterations=0)
    plans = [
        plan_routes(view, np.zeros(3, np.int64), model, cfg, MilpSelector(), "global")
        for _ in range(2)
    ]
    assert [r.stops for r in plans[0].routes] == [r.stops for r in plans[1].routes]
    g = score_routes(
        view.pending_idx,
        view.pending_delay_h,
        [(r.stops, r.energy_j) for r in plans[0].routes],
        lam,
    ).G
    assert g >= g_peer - 1e-6 * abs(g_peer)


def test_pyvrp_serves_each_parcel_only_from_its_stock_depot() -> None:
    """Parcels waiting at their own depot (``allowed`` per drone): PyVRP's routes carry
    only what their start depot stocks, and it still serves parcels from both depots."""
    model = EnergyModel()
    view = _view(seed=5, n=30)
    stock = np.where(np.arange(30) % 2 == 0, 0, 3)
    allowed = stock[None, :] == view.drone_depot[:, None]
    peer = _solve(view, lam_j(0.5, model.usable_j), model, allowed=allowed, iterations=200)
    assert {int(s) for s in peer.start} == {0, 3}
    for s, stops in zip(peer.start, peer.stops, strict=True):
        assert (stock[stops] == s).all()


def test_pyvrp_columns_of_a_mixed_fleet_fit_each_drone_s_own_payload() -> None:
    """PyVRP loads its routes to the first drone's payload (2.5 kg); a route heavier
    than a light drone's 1 kg is no column of that drone, and is never costed with its
    energy model (which refused the payload and stopped the run)."""
    from marops_cli.config import EnergyConfig
    from marops_cli.plans.planner import _add_pyvrp_routes

    heavy, light = EnergyModel(), EnergyModel(EnergyConfig(max_payload_kg=1.0))
    every = np.arange(6, dtype=np.int64)
    tasks = [DroneTask(0, -1, every, heavy), DroneTask(0, -1, every, light)]
    rng = np.random.default_rng(1)
    problem = WindowProblem.of_requests(
        np.array([[0.0, 0.0], [3000.0, 0.0]]),
        rng.uniform(-800, 800, (6, 2)),
        np.full(6, 0.8),
        np.full(6, 2.0),
        lam_j(0.5, heavy.usable_j),
        tasks,
    )
    routes: list[dict[tuple[int, ...], float]] = [{}, {}]
    _add_pyvrp_routes(problem, 200, routes)
    assert any(len(k) > 1 for k in routes[0]), "PyVRP made no multi-parcel route"
    for u, model in enumerate((heavy, light)):
        assert all(problem.weight[list(k)].sum() <= model.max_payload_kg for k in routes[u])
