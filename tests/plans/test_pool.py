"""The route pool's improvement moves, by hand (docs/method.md §4.4)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from marops_cli.energy import EnergyModel
from marops_cli.plans.pool import DroneTask, RoutePool

LAM = 200_000.0  # J per unit of v: prizes dwarf the few kJ these short routes cost


@pytest.fixture(scope="module")
def model() -> EnergyModel:
    return EnergyModel()


def _set_route(pool: RoutePool, u: int, requests: list[int], free: np.ndarray) -> None:
    dr = pool.drones[u]
    dr.stops = [int(np.flatnonzero(dr.cand == q)[0]) for q in requests]
    dr.psum = None  # its prizes are summed again when asked
    dr.energy = pool._route_energy(dr)
    dr.weight = float(pool.w[requests].sum())
    free[requests] = False


def test_exchange_swaps_a_stop_for_a_better_request_that_only_fits_without_it(model):
    """One drone at depot 0 (0, 0) landing there. Its route serves A (0, 500) 1.0 kg,
    v = 1, and B (0, -500) 1.4 kg, v = 1.5: 2.4 kg, so C (500, 0) 1.1 kg, v = 2, does
    not fit. Swapping A for C gains λ of prize and fills the payload exactly
    (1.4 + 1.1 = 2.5 kg); swapping B for C gains only λ/2 (the energies differ by a
    few kJ, λ = 200 kJ), so the route ends as {B, C}."""
    depots = np.array([[0.0, 0.0]])
    xy = np.array([[0.0, 500.0], [0.0, -500.0], [500.0, 0.0]])
    w = np.array([1.0, 1.4, 1.1])
    prize = LAM * np.array([1.0, 1.5, 2.0])
    task = DroneTask(0, 0, np.arange(3, dtype=np.int64))
    pool = RoutePool(depots, xy, w, prize, [task], model)
    free = np.ones(3, dtype=bool)
    _set_route(pool, 0, [0, 1], free)
    g_before = pool._g()
    pool._exchange([0], free, "gain")
    dr = pool.drones[0]
    served = sorted(int(dr.cand[j]) for j in dr.stops)
    assert served == [1, 2]
    assert free.tolist() == [True, False, False]
    assert dr.weight == pytest.approx(2.5, abs=1e-12)
    # The incremental energy is the route's exact energy in its order, and G grew by
    # about λ (the prize of C over A) less the change in energy.
    assert_allclose(dr.energy, pool._route_energy(dr), rtol=1e-12)
    stops = [int(dr.cand[j]) for j in dr.stops]
    pts = np.vstack([depots[0], xy[stops], depots[0]])
    assert_allclose(dr.energy, model.route_energy(pts, w[stops])[1].sum(), rtol=1e-9)
    assert pool._g() - g_before == pytest.approx(LAM, abs=10_000.0)


def test_exchange_keeps_a_route_no_swap_improves(model):
    """The same drone with every prize equal and C 1500 m away: a swap for C gains no
    prize and lengthens the route by more than a kilometre, so nothing changes."""
    depots = np.array([[0.0, 0.0]])
    xy = np.array([[0.0, 500.0], [0.0, -500.0], [1500.0, 0.0]])
    w = np.array([1.0, 1.4, 1.1])
    pool = RoutePool(depots, xy, w, np.full(3, LAM), [DroneTask(0, 0, np.arange(3))], model)
    free = np.ones(3, dtype=bool)
    _set_route(pool, 0, [0, 1], free)
    before = (list(pool.drones[0].stops), pool.drones[0].energy)
    pool._exchange([0], free, "gain")
    assert (list(pool.drones[0].stops), pool.drones[0].energy) == before
    assert free.tolist() == [False, False, True]


@pytest.mark.parametrize("seed", range(12))
def test_ruin_near_removes_the_stops_nearest_one_served_stop(model, seed):
    """Three drones with four stops each: the ruin frees 2 to 5 served stops, which are
    the ones nearest one of them (any three routes may lose stops here), marks them
    free, and leaves every route's energy and weight exact."""
    rng = np.random.default_rng(seed)
    depots = rng.uniform(0, 3000, (3, 2))
    xy = rng.uniform(0, 3000, (14, 2))
    w = rng.uniform(0.1, 0.5, 14)
    tasks = [DroneTask(s, -1, np.arange(14, dtype=np.int64)) for s in range(3)]
    pool = RoutePool(depots, xy, w, np.full(14, LAM), tasks, model)
    free = np.ones(14, dtype=bool)
    routes = [[0, 1, 2, 3], [4, 5, 6, 7], [8, 9, 10, 11]]
    for u, r in enumerate(routes):
        _set_route(pool, u, r, free)
    touched = pool._ruin_near([0, 1, 2], [0, 1, 2], np.random.default_rng(seed), free)
    served_before = set(sum(routes, []))
    freed = sorted(q for q in served_before if free[q])
    left = sorted(served_before - set(freed))
    assert 2 <= len(freed) <= 5
    assert not free[left].any() and free[12:].all()
    d = np.hypot(*(xy[freed][:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    assert any(d[i, freed].max() <= d[i, left].min() for i in range(len(freed)))
    for u, dr in enumerate(pool.drones):
        now = [int(dr.cand[j]) for j in dr.stops]
        assert now == [q for q in routes[u] if q not in freed]
        assert_allclose(dr.energy, pool._route_energy(dr), rtol=1e-12)
        assert dr.weight == pytest.approx(w[now].sum(), abs=1e-12)
    lost = {u for u in range(3) if len(pool.drones[u].stops) < 4}
    assert lost <= set(touched)
