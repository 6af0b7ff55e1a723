"""The route pool's improvement moves, by hand (docs/method.md §4.4)."""

from __future__ import annotations

from dataclasses import replace
from typing import NamedTuple

import numpy as np
import pytest
from numpy.testing import assert_allclose

from marops_cli.energy import EnergyModel
from marops_cli.plans.pool import DroneTask, RoutePool
from marops_cli.plans.problem import WindowProblem

LAM = 200_000.0  # J per unit of v: prizes dwarf the few kJ these short routes cost


@pytest.fixture(scope="module")
def model() -> EnergyModel:
    return EnergyModel()


class Task(NamedTuple):
    """A drone's task before it is given its model (:func:`pool_problem`)."""

    start: int
    end: int
    allowed: np.ndarray


def pool_problem(depots, xy, w, prize, tasks, model: EnergyModel) -> WindowProblem:
    """A window problem over these requests whose drones fly ``tasks`` (each of energy
    ``model``), the pool building its routes for ``prize``."""
    own = [DroneTask(t.start, t.end, np.asarray(t.allowed, dtype=np.int64), model) for t in tasks]
    problem = WindowProblem.of_requests(depots, xy, w, np.zeros(len(w)), 1.0, own)
    return replace(problem, search=np.asarray(prize, dtype=np.float64))


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
    task = Task(0, 0, np.arange(3, dtype=np.int64))
    pool = RoutePool(pool_problem(depots, xy, w, prize, [task], model))
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
    pool = RoutePool(
        pool_problem(depots, xy, w, np.full(3, LAM), [Task(0, 0, np.arange(3))], model)
    )
    free = np.ones(3, dtype=bool)
    _set_route(pool, 0, [0, 1], free)
    before = (list(pool.drones[0].stops), pool.drones[0].energy)
    pool._exchange([0], free, "gain")
    assert (list(pool.drones[0].stops), pool.drones[0].energy) == before
    assert free.tolist() == [False, False, True]


def _three_routes(model, seed: int, span: float, far: int | None = None):
    """Three drones at three depots with four stops each among 14 requests in a square of
    ``span`` metres (request ``far`` moved to 3 km, 3 km); the pool, its free mask and
    the routes."""
    rng = np.random.default_rng(seed)
    depots = rng.uniform(0, span, (3, 2))
    xy = rng.uniform(0, span, (14, 2))
    if far is not None:
        xy[far] = [3000.0, 3000.0]
    w = rng.uniform(0.1, 0.5, 14)
    tasks = [Task(s, -1, np.arange(14, dtype=np.int64)) for s in range(3)]
    pool = RoutePool(pool_problem(depots, xy, w, np.full(14, LAM), tasks, model))
    free = np.ones(14, dtype=bool)
    routes = [[0, 1, 2, 3], [4, 5, 6, 7], [8, 9, 10, 11]]
    for u, r in enumerate(routes):
        _set_route(pool, u, r, free)
    return pool, free, routes


@pytest.mark.parametrize("seed", range(12))
def test_ruin_near_removes_the_stops_nearest_one_served_stop(model, seed):
    """Three drones with four stops each: the ruin frees 2 to 8 served stops, which are
    the ones nearest one of them (any three routes may lose stops here), marks them
    free, and leaves every route's energy and weight exact."""
    pool, free, routes = _three_routes(model, seed, 3000.0)
    touched = pool._ruin_near([0, 1, 2], [0, 1, 2], np.random.default_rng(seed), free)
    served_before = set(sum(routes, []))
    freed = sorted(q for q in served_before if free[q])
    left = sorted(served_before - set(freed))
    assert 2 <= len(freed) <= 8
    assert not free[left].any() and free[12:].all()
    d = np.hypot(*(pool.xy[freed][:, None, :] - pool.xy[None, :, :]).transpose(2, 0, 1))
    assert any(d[i, freed].max() <= d[i, left].min() for i in range(len(freed)))
    for u, dr in enumerate(pool.drones):
        now = [int(dr.cand[j]) for j in dr.stops]
        assert now == [q for q in routes[u] if q not in freed]
        assert_allclose(dr.energy, pool._route_energy(dr), rtol=1e-12)
        assert dr.weight == pytest.approx(pool.w[now].sum(), abs=1e-12)
    lost = {u for u in range(3) if len(pool.drones[u].stops) < 4}
    assert lost <= set(touched)


@pytest.mark.parametrize("seed", range(8))
def test_without_is_each_routes_exact_energy_less_one_stop(model, seed):
    """The energy of a route without each of its stops, computed at once, equals the
    route's energy recomputed from scratch without that stop (the legs before it no
    longer carry its parcel; its neighbours are joined; the last stop's removal moves
    the landing), for one to six stops and both a fixed and a free landing."""
    rng = np.random.default_rng(seed)
    depots = rng.uniform(0, 3000, (4, 2))
    xy = rng.uniform(0, 3000, (8, 2))
    w = rng.uniform(0.05, 0.4, 8)
    end = -1 if seed % 2 else 2
    pool = RoutePool(
        pool_problem(depots, xy, w, np.full(8, LAM), [Task(0, end, np.arange(8))], model)
    )
    dr = pool.drones[0]
    for k in range(1, 7):
        stops = [int(x) for x in rng.permutation(8)[:k]]
        _set_route(pool, 0, stops, np.ones(8, dtype=bool))
        got = pool._without(dr)
        full = list(dr.stops)
        for i in range(k):
            dr.stops = full[:i] + full[i + 1 :]
            assert_allclose(got[i], pool._route_energy(dr), rtol=1e-12)
        dr.stops = full


@pytest.mark.parametrize("seed", range(12))
def test_ruin_worst_frees_the_costliest_detours(model, seed):
    """Three routes of four stops, one of which is a far detour (2 km off the others'
    area): the worst-detour ruin frees 2 to 8 stops from at most three routes, always
    the far one (its saving is more than twice any other's, so noise in [0.5, 1] keeps
    it first), and leaves every route's energy and weight exact."""
    pool, free, routes = _three_routes(model, seed, 1000.0, far=5)
    saving = [dr.energy - pool._without(dr) for dr in pool.drones]
    far = saving[1][1]  # request 5, second stop of drone 1
    others = [x for u, s in enumerate(saving) for i, x in enumerate(s) if (u, i) != (1, 1)]
    assert far > 2 * max(others)
    touched = pool._ruin_worst([0, 1, 2], [0, 1, 2], np.random.default_rng(seed), free)
    freed = sorted(q for q in sum(routes, []) if free[q])
    assert 2 <= len(freed) <= 8 and 5 in freed
    assert free[12:].all()
    for u, dr in enumerate(pool.drones):
        now = [int(dr.cand[j]) for j in dr.stops]
        assert now == [q for q in routes[u] if q not in freed]
        assert_allclose(dr.energy, pool._route_energy(dr), rtol=1e-12)
        assert dr.weight == pytest.approx(pool.w[now].sum(), abs=1e-12)
    assert {u for u in range(3) if len(pool.drones[u].stops) < 4} <= set(touched)


def test_a_cluster_that_pays_only_together_gets_a_route(model):
    """Delay priced low (a high α): three parcels of 0.5 kg about 2 km north of the depot,
    each with a prize of 60 % of its own flight there and back, so none pays alone and
    greedy insertion, which inserts only at a gain, would open no route. Together they
    pay: the route there with all three and back costs the flight once (plus the few
    metres between them and the heavier first leg), under 1.8 flights' worth of prizes.
    The seeded route serves all three (a 4th, 2 km south, alone and unpaid, stays out)."""
    depots = np.array([[0.0, 0.0]])
    xy = np.array([[0.0, 2000.0], [20.0, 2010.0], [-20.0, 2010.0], [0.0, -2000.0]])
    w = np.full(4, 0.5)
    alone = 2000.0 * (float(model.energy_per_m(0.5)) + float(model.energy_per_m(0.0)))
    prize = np.full(4, 0.6 * alone)
    task = Task(0, 0, np.arange(4, dtype=np.int64))
    res = RoutePool(pool_problem(depots, xy, w, prize, [task], model)).build(iterations=20, seed=0)
    assert res.routes[0], "no route: the cluster was never opened"
    best = max(
        zip(res.routes[0], res.energy_j[0], strict=True),
        key=lambda r: prize[list(r[0])].sum() - r[1],
    )
    assert sorted(best[0]) == [0, 1, 2]
    # Its energy is the exact route energy, and it pays: prizes above it.
    pts = np.vstack([depots[0], xy[list(best[0])], depots[0]])
    assert best[1] == pytest.approx(
        float(model.route_energy(pts, w[list(best[0])])[1].sum()), rel=1e-9
    )
    assert prize[list(best[0])].sum() > best[1]
    # No route serves the lone request 3, which never pays.
    assert all(3 not in r for r in res.routes[0])


def test_a_heavy_parcel_that_barely_pays_does_not_keep_a_cluster_from_its_route(model):
    """The cluster of the test above, and 1 km east a parcel at the full payload whose
    prize is 5 % above its own flight there and back: the only request that pays alone,
    so greedy insertion opens the route with it and the payload is then full. The seeds
    compete with that route: the cluster's G (about 0.8 of a 2 km flight) beats the
    heavy parcel's (5 % of a 1 km flight), and the best solution flies the cluster."""
    depots = np.array([[0.0, 0.0]])
    xy = np.array([[0.0, 2000.0], [20.0, 2010.0], [-20.0, 2010.0], [1000.0, 0.0]])
    cap = model.max_payload_kg
    w = np.array([0.5, 0.5, 0.5, cap])
    e0 = float(model.energy_per_m(0.0))
    alone = 2000.0 * (float(model.energy_per_m(0.5)) + e0)
    heavy = 1000.0 * (float(model.energy_per_m(cap)) + e0)
    prize = np.array([0.6 * alone] * 3 + [1.05 * heavy])
    task = Task(0, 0, np.arange(4, dtype=np.int64))
    pool = RoutePool(pool_problem(depots, xy, w, prize, [task], model))
    assert pool.drones[0].seedable
    res = pool.build(iterations=0, seed=0)
    g = {r: prize[list(r)].sum() - e for r, e in zip(res.routes[0], res.energy_j[0], strict=True)}
    best = max(g, key=lambda r: g[r])
    assert sorted(best) == [0, 1, 2]
    assert res.best_g == pytest.approx(g[best], rel=1e-9)
    assert res.best_g > 10 * 0.05 * heavy  # the heavy parcel's route: 5 % of its flight


def test_pair_detours_carry_both_parcels_and_are_barred_over_the_payload(model):
    """A seed's neighbours (docs/method.md §4.4, "Seeds"): the detour there and back
    between two candidates 300 m apart with 0.5 and 0.7 kg on board is 600 m at the
    1.2 kg energy per metre; two parcels that exceed the payload together get none."""
    cap = model.max_payload_kg
    depots = np.array([[0.0, 0.0]])
    xy = np.array([[0.0, 1000.0], [300.0, 1000.0], [0.0, 1300.0]])
    w = np.array([0.5, 0.7, cap - 0.6])
    task = Task(0, 0, np.arange(3, dtype=np.int64))
    pool = RoutePool(pool_problem(depots, xy, w, np.full(3, 1e6), [task], model))
    dr = pool.drones[0]
    i, j, k = (int(np.flatnonzero(dr.cand == q)[0]) for q in range(3))
    assert dr.pair_j[i, j] == pytest.approx(600.0 * float(model.energy_per_m(1.2)), rel=1e-12)
    assert dr.pair_j[j, i] == pytest.approx(dr.pair_j[i, j], rel=1e-12)
    assert dr.pair_j[i, k] == pytest.approx(600.0 * float(model.energy_per_m(cap - 0.1)), rel=1e-12)
    assert dr.pair_j[j, k] == np.inf  # 0.7 + (cap - 0.6) > cap


def test_where_every_request_pays_alone_no_seed_is_tried(model):
    """Delay priced high (α ≤ 0.5: the prize is at least a usable battery): every
    candidate pays alone, so the drone is not seedable and the pool is as before."""
    depots = np.array([[0.0, 0.0]])
    xy = np.array([[0.0, 2000.0], [0.0, -2000.0]])
    task = Task(0, 0, np.arange(2, dtype=np.int64))
    pool = RoutePool(
        pool_problem(depots, xy, np.full(2, 0.5), np.full(2, model.usable_j), [task], model)
    )
    assert not pool.drones[0].seedable


@pytest.mark.parametrize("pack", [0.0, 0.5, 1.0])
def test_pack_price_prices_each_loaded_leg_toward_the_full_payload(model, pack):
    """One drone at depot 0 (0, 0) landing there, one 0.5 kg parcel at (0, 1000): the
    route flies 1,000 m with 0.5 kg and 1,000 m back empty. ``pack_price`` p prices the
    loaded leg at (1 − p) e(0.5) + p e(2.5) J/m and leaves the empty leg as it is."""
    depots, xy, w = np.array([[0.0, 0.0]]), np.array([[0.0, 1000.0]]), np.array([0.5])
    task = Task(0, 0, np.arange(1, dtype=np.int64))
    pool = RoutePool(pool_problem(depots, xy, w, [LAM], [task], model), pack=pack)
    res = pool.build(iterations=0)
    e = model.energy_per_m
    loaded = (1.0 - pack) * float(e(0.5)) + pack * float(e(2.5))
    assert res.routes == [[(0,)]]
    assert_allclose(res.energy_j[0][0], 1000.0 * loaded + 1000.0 * float(e(0.0)), rtol=1e-9)


def test_pack_price_leaves_a_light_parcel_whose_flight_pays_only_at_its_own_weight(model):
    """The same parcel with a prize halfway between its route's exact energy and that
    energy priced with the loaded leg at the full payload: it is flown without the price
    and left with ``pack_price = 1``."""
    depots, xy, w = np.array([[0.0, 0.0]]), np.array([[0.0, 1000.0]]), np.array([0.5])
    e = model.energy_per_m
    exact = 1000.0 * float(e(0.5)) + 1000.0 * float(e(0.0))
    full = 1000.0 * float(e(2.5)) + 1000.0 * float(e(0.0))
    assert full > exact * 1.05  # the full payload costs more per metre, by more than 5 %
    task = Task(0, 0, np.arange(1, dtype=np.int64))
    problem = pool_problem(depots, xy, w, [(exact + full) / 2], [task], model)
    assert RoutePool(problem).build(iterations=20).routes == [[(0,)]]
    assert RoutePool(problem, pack=1.0).build(iterations=20).routes == [[]]
