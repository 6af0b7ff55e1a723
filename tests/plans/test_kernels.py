"""The route pool's compiled kernels give numpy's numbers to the bit, and are loaded when
they pay (docs/decisions.md, "The route pool")."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from marops_cli.energy import EnergyModel
from marops_cli.plans import _jit
from marops_cli.plans import kernels as kernels_mod
from marops_cli.plans.pool import DroneTask, RoutePool, build_pool

from .test_pool import pool_problem


@pytest.fixture(scope="module")
def model() -> EnergyModel:
    return EnergyModel()


@pytest.fixture(autouse=True)
def fresh_loader(monkeypatch):
    """Each test starts with the loader as a new process has it (kernels not tried)."""
    monkeypatch.setattr(kernels_mod, "_pools", 0)
    monkeypatch.setattr(kernels_mod, "_tried", False)
    monkeypatch.setattr(kernels_mod, "_loaded", None)
    monkeypatch.delenv(kernels_mod.JIT_ENV, raising=False)


def _window(model: EnergyModel, seed: int, n_req: int = 40, n_drones: int = 4):
    """A random window: depots, requests (some heavy, some far) and free-landing drones
    that may serve anything."""
    rng = np.random.default_rng(seed)
    depots = rng.uniform(0, 6000, (6, 2))
    xy = rng.uniform(0, 6000, (n_req, 2))
    w = rng.choice([0.2, 0.5, 0.9, 1.3, 2.4], n_req)
    prize = 60_000.0 * (1.0 + rng.uniform(0, 3, n_req))
    starts = rng.integers(0, 6, n_drones)
    ends = [-1 if u % 2 == 0 else int(rng.integers(6)) for u in range(n_drones)]
    tasks = [
        DroneTask(int(s), e, np.arange(n_req, dtype=np.int64), model)
        for s, e in zip(starts, ends, strict=True)
    ]
    return depots, xy, w, prize, tasks


def _pool_pair(model, seed):
    """The same pool twice: one on the kernels, one on numpy."""
    args = _window(model, seed)
    jit = RoutePool(pool_problem(*args, model))
    jit._jit = kernels_mod.load_kernels()
    plain = RoutePool(pool_problem(*args, model))
    plain._jit = None
    assert jit._jit is _jit
    return jit, plain


def test_interpolation_is_numpys_to_the_bit(model):
    """Loads on the grid's points, between them, at and beyond the payload: the same
    floats as np.interp over the energy model's table."""
    rng = np.random.default_rng(3)
    grid, table = model.grid_kg, model.table_j_per_m
    loads = np.concatenate(
        [grid[::7], rng.uniform(0, grid[-1], 500), grid[-1] + [0.0, 1e-9, 0.3], [0.0]]
    )
    got = np.array([_jit._interp(x, grid, table) for x in loads])
    assert_array_equal(got, np.interp(loads, grid, table))


@pytest.mark.parametrize("seed", range(4))
def test_insertion_and_refresh_are_numpys_to_the_bit(model, seed):
    """Routes of 0 to 11 stops on each drone (past numpy's 8-element blocks); each
    route's energy and its energies without each stop, and every candidate's extra
    energy, slot and score (each construction score, blurred or not) equal numpy's
    exactly, and so does the best score each refresh returns."""
    jit, plain = _pool_pair(model, seed)
    rng = np.random.default_rng(seed)
    for u in range(len(jit.drones)):
        for n_stops in range(12):
            m = jit.drones[u].cand.size
            stops = rng.choice(m, min(n_stops, m), replace=False).tolist()
            for pool in (jit, plain):
                dr = pool.drones[u]
                dr.stops = list(stops)
                dr.energy = pool._route_energy(dr)
                dr.weight = float(dr.cand_w[stops].sum())
            assert jit.drones[u].energy == plain.drones[u].energy
            if stops:
                assert_array_equal(jit._without(jit.drones[u]), plain._without(plain.drones[u]))
            sub = np.flatnonzero(rng.random(m) < 0.7)
            a, b = jit._insertion(jit.drones[u], sub), plain._insertion(plain.drones[u], sub)
            assert_array_equal(a[0], b[0])
            assert_array_equal(a[1], b[1])
            free = rng.random(jit.w.size) < 0.8
            for kind in ("density", "weight", "gain"):
                for blur in (False, True):
                    best = [
                        pool._refresh(u, kind, free, np.random.default_rng(7) if blur else None)
                        for pool in (jit, plain)
                    ]
                    assert best[0] == best[1]
                    dj, dp = jit.drones[u], plain.drones[u]
                    assert_array_equal(dj.score, dp.score)
                    live = np.isfinite(dp.score)
                    assert_array_equal(dj.slot[live], dp.slot[live])
                    assert_array_equal(dj.d_e[live], dp.d_e[live])


@pytest.mark.parametrize("seed", [11, 12])
def test_a_whole_pool_is_the_same_with_or_without_the_kernels(model, seed, monkeypatch):
    """Constructions, exchanges and ruin and recreate: the same routes, the same
    energies to the bit."""
    args = _window(model, seed, n_req=60, n_drones=5)
    monkeypatch.setenv(kernels_mod.JIT_ENV, "0")
    plain = build_pool(pool_problem(*args, model), iterations=40, seed=seed)
    monkeypatch.setenv(kernels_mod.JIT_ENV, "1")
    pool = RoutePool(pool_problem(*args, model))
    assert pool._jit is _jit
    jit = pool.build(40, seed)
    assert jit.routes == plain.routes and jit.energy_j == plain.energy_j
    assert jit.best_g == plain.best_g and sum(map(len, jit.routes)) > 5


def test_the_kernels_wait_for_a_days_windows(monkeypatch):
    """Unset: numpy for the first NUMPY_POOLS pools, the kernels after; 0: never;
    1: from the first pool."""
    got = [kernels_mod.kernels() for _ in range(kernels_mod.NUMPY_POOLS + 2)]
    assert got[: kernels_mod.NUMPY_POOLS] == [None] * kernels_mod.NUMPY_POOLS
    assert got[-2:] == [_jit, _jit]
    monkeypatch.setenv(kernels_mod.JIT_ENV, "0")
    assert kernels_mod.kernels() is None
    monkeypatch.setattr(kernels_mod, "_tried", False)
    monkeypatch.setattr(kernels_mod, "_pools", 0)
    monkeypatch.setenv(kernels_mod.JIT_ENV, "1")
    assert kernels_mod.kernels() is _jit


def test_a_kernel_that_fails_to_compile_leaves_numpy(model, monkeypatch):
    """A machine numba cannot compile for: the pool plans with numpy, the same routes."""

    def broken() -> None:
        raise RuntimeError("no target for this machine")

    monkeypatch.setattr(_jit, "warm_up", broken)
    monkeypatch.setenv(kernels_mod.JIT_ENV, "1")
    args = _window(model, 5)
    pool = RoutePool(pool_problem(*args, model))
    assert pool._jit is None and kernels_mod.load_kernels() is None
    res = pool.build(20, 5)
    assert sum(map(len, res.routes)) > 0
