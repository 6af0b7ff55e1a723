"""Visiting order: the subset DP against brute force, and the paper's greedy order."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from numpy.testing import assert_allclose

from marops_cli.energy import EnergyModel
from marops_cli.plans.order import MAX_STOPS, best_order, subset_orders

START, END = (0.0, 0.0), (400.0, -300.0)


@pytest.fixture(scope="module")
def model() -> EnergyModel:
    return EnergyModel()


def _route_j(model, xy, w, perm, start=START, end=END) -> float:
    pts = np.vstack([start, xy[list(perm)], end])
    return float(model.route_energy(pts, w[list(perm)])[1].sum())


def _instance(seed: int, n: int):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-1500, 1500, (n, 2))
    w = rng.uniform(0.05, 2.5 / n, n)
    if seed % 3 == 0:  # a heavy parcel among light ones: order matters most here
        w[rng.integers(n)] = 2.5 - w.sum() + 0.05
    return xy, w


@pytest.mark.parametrize("n", range(1, 8))
@pytest.mark.parametrize("seed", range(3))
def test_exact_order_equals_brute_force(model, n, seed):
    xy, w = _instance(seed * 10 + n, n)
    orders = subset_orders(START, END, xy, w, model, "exact")
    full = (1 << n) - 1
    best = min(_route_j(model, xy, w, p) for p in itertools.permutations(range(n)))
    assert_allclose(orders.energy_j[full], best, rtol=1e-10)
    assert sorted(orders.route(full)) == list(range(n))
    # every smaller subset too (the same DP table answers them all)
    rng = np.random.default_rng(seed)
    for mask in rng.integers(1, full + 1, size=min(full, 8)):
        members = [j for j in range(n) if mask >> j & 1]
        brute = min(
            _route_j(model, xy, w, p) for p in itertools.permutations(members, len(members))
        )
        assert_allclose(orders.energy_j[mask], brute, rtol=1e-10)


@pytest.mark.parametrize("method", ["exact", "greedy"])
def test_reported_energy_and_distance_are_those_of_the_reported_route(model, method):
    xy, w = _instance(7, 6)
    orders = subset_orders(START, END, xy, w, model, method)
    for mask in range(1 << 6):
        route = orders.route(mask)
        assert sorted(route) == [j for j in range(6) if mask >> j & 1]
        assert orders.size[mask] == len(route)
        pts = np.vstack([START, xy[list(route)], END])
        legs_m, legs_j = model.route_energy(pts, w[list(route)])
        assert_allclose(orders.distance_m[mask], legs_m.sum(), rtol=1e-12)
        assert_allclose(orders.energy_j[mask], legs_j.sum(), rtol=1e-12)
        assert_allclose(orders.weight_kg[mask], w[list(route)].sum(), rtol=1e-12)


def test_energy_md_example_exact_takes_heavy_parcel_first(model):
    depot, a, b = (0, 0), (600, 0), (0, 700)  # A 0.1 kg (nearer), B 2.0 kg
    assert best_order(depot, depot, [a, b], [0.1, 2.0], model, "exact") == (1, 0)
    assert best_order(depot, depot, [a, b], [0.1, 2.0], model, "greedy") == (0, 1)
    exact = subset_orders(depot, depot, [a, b], [0.1, 2.0], model, "exact").energy_j[3]
    greedy = subset_orders(depot, depot, [a, b], [0.1, 2.0], model, "greedy").energy_j[3]
    assert_allclose(exact, 43_466.7, rtol=1e-3)
    assert_allclose(greedy, 51_413.6, rtol=1e-3)
    assert_allclose(1 - exact / greedy, 0.155, atol=5e-4)


def _nearest_neighbour(xy, members, start):
    here, route, left = np.asarray(start), [], list(members)
    while left:
        j = min(left, key=lambda k: (np.hypot(*(xy[k] - here)), k))
        route.append(j)
        left.remove(j)
        here = xy[j]
    return tuple(route)


@pytest.mark.parametrize("seed", range(5))
def test_greedy_is_nearest_neighbour_by_distance(model, seed):
    xy, w = _instance(100 + seed, 7)
    orders = subset_orders(START, END, xy, w, model, "greedy")
    for mask in range(1 << 7):
        members = [j for j in range(7) if mask >> j & 1]
        assert orders.route(mask) == _nearest_neighbour(xy, members, START)


def test_exact_never_worse_than_greedy(model):
    for seed in range(10):
        xy, w = _instance(200 + seed, 6)
        exact = subset_orders(START, END, xy, w, model, "exact")
        greedy = subset_orders(START, END, xy, w, model, "greedy")
        feasible = np.isfinite(exact.energy_j)
        assert np.all(exact.energy_j[feasible] <= greedy.energy_j[feasible] * (1 + 1e-12))


def test_overweight_subsets_get_infinite_energy(model):
    orders = subset_orders(START, END, [(100, 0), (0, 100), (50, 50)], [1.5, 1.5, 0.5], model)
    assert np.isinf(orders.energy_j[0b011]) and np.isinf(orders.energy_j[0b111])
    assert np.isfinite(orders.energy_j[0b101]) and np.isfinite(orders.energy_j[0b110])


def test_no_candidates_is_the_direct_flight(model):
    orders = subset_orders(START, END, np.empty((0, 2)), [], model)
    assert orders.order.shape == (1, 0)
    assert_allclose(orders.distance_m, [500.0])
    assert_allclose(orders.energy_j, [500.0 * model.energy_per_m(0.0)])


def test_coincident_points(model):
    orders = subset_orders((0, 0), (0, 0), [(0, 0), (0, 0), (10, 0)], [0.5, 0.5, 0.5], model)
    assert np.all(np.isfinite(orders.energy_j))
    assert_allclose(orders.distance_m[-1], 20.0)


def test_twelve_candidates_run_and_more_are_refused(model):
    xy, w = _instance(5, MAX_STOPS)
    orders = subset_orders(START, END, xy, w, model)
    assert orders.order.shape == (1 << MAX_STOPS, MAX_STOPS)
    with pytest.raises(ValueError, match="at most 12"):
        subset_orders(START, END, np.zeros((13, 2)), np.full(13, 0.1), model)
    with pytest.raises(ValueError, match="one location per parcel"):
        subset_orders(START, END, np.zeros((3, 2)), [0.1, 0.2], model)
    with pytest.raises(ValueError, match="ordering"):
        subset_orders(START, END, np.zeros((2, 2)), [0.1, 0.2], model, "random")  # type: ignore[arg-type]


def test_batched_subset_energies_match_brute_force(model: EnergyModel) -> None:
    """subset_energies (a batch of drones, padded) = the best permutation of each subset."""
    from marops_cli.plans.order import subset_energies

    rng = np.random.default_rng(7)
    sizes = [4, 2, 0, 3]
    n = max(sizes)
    xy = np.full((len(sizes), n, 2), np.nan)
    w = np.full((len(sizes), n), np.inf)
    starts = rng.uniform(-800, 800, (len(sizes), 2))
    ends = rng.uniform(-800, 800, (len(sizes), 2))
    for b, k in enumerate(sizes):
        xy[b, :k] = rng.uniform(-1500, 1500, (k, 2))
        w[b, :k] = rng.uniform(0.1, 1.2, k)
    energy, weight, bits = subset_energies(starts, ends, xy, w, model)
    assert energy.shape == weight.shape == (len(sizes), 1 << n)
    for b, k in enumerate(sizes):
        for mask in range(1 << n):
            members = np.flatnonzero(bits[mask])
            if members.size and members.max() >= k:  # holds a pad: never a plan
                assert energy[b, mask] == np.inf
                continue
            if w[b, members].sum() > model.max_payload_kg:
                assert energy[b, mask] == np.inf
                continue
            best = min(
                _route_j(model, xy[b], w[b], perm, starts[b], ends[b])
                for perm in itertools.permutations(members.tolist())
            )
            assert energy[b, mask] == pytest.approx(best, rel=1e-9)


def test_free_end_energies_land_at_the_depot_nearest_the_last_customer(
    model: EnergyModel,
) -> None:
    """With ``free_end_m`` the route ends at the depot nearest its last customer (empty
    route: stays): brute force over orders and that landing."""
    from marops_cli.plans.order import subset_energies

    rng = np.random.default_rng(11)
    depots = rng.uniform(-2000, 2000, (5, 2))
    xy = rng.uniform(-1500, 1500, (1, 3, 2))
    w = rng.uniform(0.1, 1.0, (1, 3))
    start = depots[2][None, :]
    near_m = np.hypot(*(xy[0, :, None, :] - depots[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    energy, _, bits = subset_energies(start, start, xy, w, model, free_end_m=near_m[None, :])
    assert energy[0, 0] == 0.0  # nothing to deliver: the drone stays
    for mask in range(1, 8):
        members = np.flatnonzero(bits[mask]).tolist()
        best = np.inf
        for perm in itertools.permutations(members):
            last = xy[0, perm[-1]]
            end = depots[np.argmin(np.hypot(*(depots - last).T))]
            best = min(best, _route_j(model, xy[0], w[0], perm, start[0], end))
        assert energy[0, mask] == pytest.approx(best, rel=1e-9)


def test_fixed_and_free_routes_share_one_call(model: EnergyModel) -> None:
    """A row of ``free_end_m`` that is all NaN keeps its fixed end: one call over a fixed
    and a free row gives, bit for bit, what a call for each gives."""
    from marops_cli.plans.order import subset_energies

    rng = np.random.default_rng(12)
    xy = rng.uniform(-1500, 1500, (2, 4, 2))
    w = rng.uniform(0.1, 1.0, (2, 4))
    starts, ends = rng.uniform(-2000, 2000, (2, 2)), rng.uniform(-2000, 2000, (2, 2))
    near = rng.uniform(100, 900, 4)
    free = np.vstack([np.full(4, np.nan), near])
    both, _, _ = subset_energies(starts, ends, xy, w, model, free_end_m=free)
    fixed, _, _ = subset_energies(starts[:1], ends[:1], xy[:1], w[:1], model)
    alone, _, _ = subset_energies(starts[1:], ends[1:], xy[1:], w[1:], model, near[None, :])
    assert np.array_equal(both[0], fixed[0]) and np.array_equal(both[1], alone[0])
    assert not np.array_equal(
        both[1], subset_energies(starts[1:], ends[1:], xy[1:], w[1:], model)[0][0]
    )
