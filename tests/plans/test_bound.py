"""The window bound (docs/method.md, "The bound") against brute force over every route."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import linprog

from marops_cli.config import PlanConfig
from marops_cli.energy import EnergyModel
from marops_cli.plans import pricing
from marops_cli.plans.bound import BoundCaps, bound_g, window_bound
from marops_cli.plans.objective import lam_j
from marops_cli.plans.pool import DroneTask, build_pool
from marops_cli.plans.pricing import DroneClass, price
from marops_cli.plans.problem import WindowProblem
from marops_cli.plans.select import MilpSelector
from marops_cli.plans.window import plan_routes
from marops_cli.segment.depots import nearest_depot

from .test_pool import Task, pool_problem
from .test_window import hand_view

ALPHA = 0.5


def _problem(depots, xy, w, value, lam, tasks, model) -> WindowProblem:
    """The window problem of these requests (value v each) for drones of ``model``."""
    own = [DroneTask(t.start, t.end, np.asarray(t.allowed, dtype=np.int64), model) for t in tasks]
    return WindowProblem.of_requests(depots, xy, w, np.asarray(value) - 1.0, lam, own)


def _bound(depots, xy, w, value, lam, tasks, model, *, columns=None, plan=False, **caps):
    """:func:`bound_g` of :func:`_problem`, capped by ``caps`` (:class:`BoundCaps`)."""
    problem = _problem(depots, xy, w, value, lam, tasks, model)
    return bound_g(problem, columns=columns, caps=BoundCaps(**caps), plan=plan)


@pytest.fixture(scope="module")
def model() -> EnergyModel:
    return EnergyModel()


def _energy(depots, xy, w, task: DroneTask, order, model: EnergyModel) -> float:
    """Exact payload-aware energy of visiting ``order`` (positions), with the landing rule."""
    if not order:
        end = task.start if task.end < 0 else task.end
        return float(model.leg_energy_j(np.hypot(*(depots[end] - depots[task.start])), 0.0))
    pts = xy[list(order)]
    end = int(nearest_depot(pts[-1], depots)[0][0]) if task.end < 0 else task.end
    path = np.vstack([depots[task.start], pts, depots[end]])
    return float(model.route_energy(path, w[list(order)])[1].sum())


def _all_routes(depots, xy, w, task, model) -> dict[tuple[int, ...], float]:
    """Every feasible non-empty subset of a drone's requests with its least energy."""
    out: dict[tuple[int, ...], float] = {}
    allowed = [int(i) for i in task.allowed]
    for k in range(1, len(allowed) + 1):
        for sub in itertools.combinations(allowed, k):
            if not model.fits(w[list(sub)].sum()):
                continue
            e = min(_energy(depots, xy, w, task, p, model) for p in itertools.permutations(sub))
            if model.fits(energy_j=e):
                out[sub] = e
    return out


def _window(seed: int, n_drones: int, n_req: int):
    rng = np.random.default_rng(seed)
    depots = rng.uniform(0, 4000, (3, 2))
    xy = rng.uniform(0, 4000, (n_req, 2))
    w = rng.uniform(0.2, 1.4, n_req)
    value = 1.0 + rng.uniform(0, 2, n_req)
    tasks = []
    for _ in range(n_drones):
        s = int(rng.integers(3))
        end = int(rng.integers(-1, 3))
        allowed = np.flatnonzero(rng.random(n_req) < 0.8).astype(np.int64)
        tasks.append(Task(s, end, allowed))
    return depots, xy, w, value, tasks


def _brute(depots, xy, w, value, tasks, model, lam):
    """The set-packing optimum and its linear relaxation over every feasible route."""
    prize = lam * value
    empty = [_energy(depots, xy, w, t, (), model) for t in tasks]
    cols = []  # (drone, subset, G − G_empty)
    for u, t in enumerate(tasks):
        for sub, e in _all_routes(depots, xy, w, t, model).items():
            cols.append((u, sub, float(prize[list(sub)].sum()) - e + empty[u]))
    const = -sum(empty)
    # Integer: drones one by one, states = requests taken.
    states = {(): 0.0}
    for u in range(len(tasks)):
        nxt = dict(states)
        for taken, g in states.items():
            for v, sub, gk in cols:
                if v == u and not set(sub) & set(taken):
                    key = tuple(sorted(taken + sub))
                    nxt[key] = max(nxt.get(key, -np.inf), g + gk)
        states = nxt
    ip = const + max(states.values())
    # Linear relaxation.
    a = np.zeros((len(tasks) + w.size, len(cols)))
    for k, (u, sub, _) in enumerate(cols):
        a[u, k] = 1.0
        a[len(tasks) + np.array(sub), k] = 1.0
    lp = linprog(
        -np.array([c[2] for c in cols]), A_ub=a, b_ub=np.ones(a.shape[0]), bounds=(0, None)
    )
    return ip, const - lp.fun


def _columns(pool) -> list[list[tuple[tuple[int, ...], float]]]:
    """A route pool's routes as each drone's known columns (a warm start)."""
    return [list(zip(r, e, strict=True)) for r, e in zip(pool.routes, pool.energy_j, strict=True)]


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("reach", [False, True])
def test_bound_is_above_the_optimum_and_equals_the_relaxation_when_elementary(
    seed, reach, model, monkeypatch
):
    if reach:  # the knapsack tables by reach, which only larger windows build otherwise
        monkeypatch.setattr(pricing, "_REACH_MIN", 0)
    n_drones, n_req = 2 + seed % 2, 5 + seed % 3
    depots, xy, w, value, tasks = _window(seed, n_drones, n_req)
    lam = lam_j(ALPHA, model.usable_j)
    ip, lp = _brute(depots, xy, w, value, tasks, model, lam)
    res = _bound(depots, xy, w, value, lam, tasks, model, ng=n_req)
    assert res.converged and res.priced and res.capped == ""
    assert res.bound >= ip - 1e-6
    assert res.bound == pytest.approx(lp, rel=1e-6, abs=1e-3)
    # ng-routes (neighbourhoods of two) only loosen the bound.
    loose = _bound(depots, xy, w, value, lam, tasks, model, ng=2)
    assert loose.bound >= res.bound - 1e-3
    # The route pool's best plan, warm-starting the master, stays under the bound.
    pool = build_pool(pool_problem(depots, xy, w, lam * value, tasks, model), iterations=20)
    assert res.bound >= pool.best_g - 1e-6
    warm = _bound(depots, xy, w, value, lam, tasks, model, ng=n_req, columns=_columns(pool))
    assert warm.bound == pytest.approx(lp, rel=1e-6, abs=1e-3)


@pytest.mark.parametrize("seed", range(4))
def test_best_plan_over_the_bounds_routes_is_feasible_and_at_most_the_optimum(seed, model):
    """The plan the bound's routes give (``plan=True``): one route per drone of the
    drone's own requests, each request once, within payload and battery, G as its
    routes' exact energies say, between the warm start's best plan and the optimum."""
    depots, xy, w, value, tasks = _window(10 + seed, 2 + seed % 2, 6)
    lam = lam_j(ALPHA, model.usable_j)
    ip, _ = _brute(depots, xy, w, value, tasks, model, lam)
    pool = build_pool(pool_problem(depots, xy, w, lam * value, tasks, model), iterations=20)
    cols = _columns(pool)
    res = _bound(depots, xy, w, value, lam, tasks, model, ng=6, plan=True, columns=cols)
    assert res.plan is not None and len(res.plan) == len(tasks)
    seen: list[int] = []
    g = 0.0
    for task, (stops, end) in zip(tasks, res.plan, strict=True):
        assert end == task.end and set(stops) <= set(task.allowed.tolist())
        assert model.fits(w[list(stops)].sum())
        e = _energy(depots, xy, w, task, stops, model)
        assert model.fits(energy_j=e)
        g += float(lam * value[list(stops)].sum()) - e
        seen += list(stops)
    assert len(seen) == len(set(seen))
    assert res.plan_g == pytest.approx(g, abs=1e-3)
    assert pool.best_g - 1e-6 <= res.plan_g <= ip + 1e-6


def test_capped_search_still_returns_a_valid_bound(model):
    depots, xy, w, value, tasks = _window(3, 3, 7)
    lam = lam_j(ALPHA, model.usable_j)
    ip, _ = _brute(depots, xy, w, value, tasks, model, lam)
    res = _bound(depots, xy, w, value, lam, tasks, model, max_iterations=0)
    assert not res.priced and res.capped == "iterations"
    assert res.bound >= ip - 1e-6
    # A round or two, and a full pricing cut short by its label cap: still above.
    for cap in ({"max_iterations": 1}, {"max_iterations": 2}, {"max_labels": 1}):
        res = _bound(depots, xy, w, value, lam, tasks, model, **cap)
        assert res.priced and res.bound >= ip - 1e-6
    # The work cap counts labels, not seconds: the same bound on every run.
    runs = [_bound(depots, xy, w, value, lam, tasks, model, max_work=5) for _ in range(2)]
    assert runs[0].capped == "work" and runs[0].priced and runs[0].bound >= ip - 1e-6
    assert (runs[0].bound, runs[0].labels) == (runs[1].bound, runs[1].labels)


def test_one_drone_one_request_by_hand(model):
    """Depot 0 at (0, 0), depot 1 at (3000, 0); one request at (1000, 0), 1 kg, 2 h late
    (v = 3). The drone starts at depot 0 and lands freely: the only route flies 1000 m
    with 1 kg and 1000 m back empty (depot 0 is the nearer), so the bound is exactly
    λ·3 − E, the best plan's G."""
    depots = np.array([[0.0, 0.0], [3000.0, 0.0]])
    xy = np.array([[1000.0, 0.0]])
    w = np.array([1.0])
    task = Task(0, -1, np.array([0], dtype=np.int64))
    lam = lam_j(ALPHA, model.usable_j)  # α = 0.5: λ = E_ref = 168,750 J
    assert lam == pytest.approx(168_750.0)
    e = 1000.0 * float(model.energy_per_m(1.0)) + 1000.0 * float(model.energy_per_m(0.0))
    res = _bound(depots, xy, w, np.array([3.0]), lam, [task], model)
    assert res.bound == pytest.approx(3 * 168_750.0 - e, abs=1e-3)
    # A second drone, identical, adds nothing: the request is served once.
    res2 = _bound(depots, xy, w, np.array([3.0]), lam, [task, task], model)
    assert res2.bound == pytest.approx(res.bound, abs=1e-3)


def test_two_requests_over_payload_by_hand(model):
    """One drone at (0, 0) landing there; requests at (0, 1000) 1.5 kg v = 1 and
    (0, -1000) 1.5 kg v = 2: together 3 kg, over the 2.5 kg payload, so the relaxation
    serves the second alone: λ·2 − 2000 m of flight (1000 m with 1.5 kg, 1000 m empty)."""
    depots = np.array([[0.0, 0.0]])
    xy = np.array([[0.0, 1000.0], [0.0, -1000.0]])
    w = np.array([1.5, 1.5])
    task = Task(0, 0, np.array([0, 1], dtype=np.int64))
    lam = lam_j(ALPHA, model.usable_j)
    e = 1000.0 * float(model.energy_per_m(1.5)) + 1000.0 * float(model.energy_per_m(0.0))
    res = _bound(depots, xy, w, np.array([1.0, 2.0]), lam, [task], model)
    assert res.bound == pytest.approx(2 * lam - e, abs=1e-3)


def test_pricing_finds_the_best_route_of_a_drone(model):
    """With no prices the exact pricing's best is the best single route by brute force."""
    depots, xy, w, value, tasks = _window(7, 1, 6)
    lam = lam_j(ALPHA, model.usable_j)
    t = tasks[0]
    routes = _all_routes(depots, xy, w, t, model)
    empty = _energy(depots, xy, w, t, (), model)
    best = max(lam * value[list(s)].sum() - e + empty for s, e in routes.items())
    land = nearest_depot(xy, depots)[1]
    problem = _problem(depots, xy, w, value, lam, tasks, model)
    cls = DroneClass.of(problem.tasks[0], problem, land, 1, 6)
    pr = price(cls, lam * value, 0.0)
    assert pr.exact
    assert pr.best == pytest.approx(best, rel=1e-9)
    stops, e, v = pr.routes[0]
    assert v == pytest.approx(best, rel=1e-9)
    assert e == pytest.approx(_energy(depots, xy, w, t, stops, model), rel=1e-9)


def test_plan_config_bound_is_off_by_default_and_left_out_of_dumps():
    assert PlanConfig().bound is False
    assert "bound" not in PlanConfig().model_dump()
    assert PlanConfig(bound=True).model_dump()["bound"] is True


def test_bound_labels_sets_the_search_caps(monkeypatch, model):
    """``[plan] bound_labels`` is the work cap of every window's bound, and a 25th of it
    (at least the default 20,000) the labels of one length; left out of dumps at its
    default, so the run identities of earlier runs stay as they were."""
    import marops_cli.plans.bound as bound_mod

    assert "bound_labels" not in PlanConfig().model_dump()
    assert PlanConfig(bound_labels=2_000_000).model_dump()["bound_labels"] == 2_000_000
    seen: list[dict] = []
    real = bound_mod.bound_g
    monkeypatch.setattr(bound_mod, "bound_g", lambda *a, **kw: seen.append(kw) or real(*a, **kw))
    view, acts = hand_view(), np.array([0, 1])
    for labels in (1_000, 500_000, 2_000_000):
        window_bound(view, acts, model, PlanConfig(bound=True, bound_labels=labels))
    assert [(kw["caps"].max_work, kw["caps"].max_labels) for kw in seen] == [
        (1_000, 20_000),
        (500_000, 20_000),
        (2_000_000, 80_000),
    ]
    # A cap given by the caller wins.
    window_bound(view, acts, model, PlanConfig(bound_labels=2_000_000), max_work=7)
    assert seen[-1]["caps"].max_work == 7 and seen[-1]["caps"].max_labels == 80_000


@pytest.mark.parametrize(("planner", "scope"), [("pool", "range"), ("subsets", "global")])
def test_plan_routes_records_the_bound_only_when_asked(planner, scope, model):
    """The hand instance of test_window.py: the bound is at least the plan's G, the
    objective's record gains ``bound_G`` and ``gap`` with the option on and is as
    before with it off."""
    view, acts = hand_view(), np.array([0, 1])
    off = plan_routes(view, acts, model, PlanConfig(planner=planner), MilpSelector(), scope)
    assert off.bound is None and set(off.score.as_dict()) == {
        "J",
        "G",
        "energy_j",
        "served",
        "pending",
    }
    cfg = PlanConfig(planner=planner, bound=True)
    on = plan_routes(view, acts, model, cfg, MilpSelector(), scope)
    sc = on.score.as_dict()
    assert sc["G"] >= off.score.G  # the bound's routes may give a better plan, never worse
    assert sc["bound_G"] >= sc["G"] - 1e-6 and sc["gap"] >= -1e-9
    assert on.bound.converged and sc["bound_G"] == on.bound.bound
    # Landing freely and serving anything bounds every planner's plan too.
    relaxed = window_bound(view, acts, model, cfg, relaxed=True)
    assert relaxed.bound >= sc["G"] - 1e-6


def test_a_wide_window_is_priced_within_its_work(monkeypatch, model):
    """800 requests, one drone: every label of a pricing scans all of them when it is
    extended, so the work cap counts a label for 800 / 256 of one. The label × request
    entries the search forms stay within the cap's (20,000 · 256), where the labels
    alone let one round form tens of millions; the bound stays above the plan found."""
    rng = np.random.default_rng(5)
    n = 800
    depots = np.array([[0.0, 0.0], [3000.0, 3000.0]])
    xy = rng.uniform(0, 3000, (n, 2))
    w = rng.uniform(0.2, 1.4, n)
    value = 1.0 + rng.uniform(0, 2, n)
    lam = lam_j(ALPHA, model.usable_j)
    entries = [0]
    real = pricing._extend

    def counted(lab, idx, within, bar):
        entries[0] += lab.size * within.pps.size
        return real(lab, idx, within, bar)

    monkeypatch.setattr(pricing, "_extend", counted)
    task = Task(0, -1, np.arange(n, dtype=np.int64))
    res = _bound(depots, xy, w, value, lam, [task], model, max_work=20_000, plan=True)
    assert 0 < entries[0] <= 20_000 * 256
    assert res.priced and res.capped == "work" and res.work <= 20_000
    assert res.bound >= res.plan_g - 1e-6


@pytest.mark.parametrize("seed", range(4))
def test_a_bound_cut_by_its_work_or_its_size_stays_above_the_optimum(seed, model, monkeypatch):
    """Every pricing counted as wide (a label as many units as requests), so the work
    limit stops pricings between levels or before they start; or every class wider than
    the pricing takes, bounded by its knapsack alone: the bound stays above the brute
    force optimum whatever stops it."""
    depots, xy, w, value, tasks = _window(20 + seed, 2 + seed % 2, 6)
    lam = lam_j(ALPHA, model.usable_j)
    ip, _ = _brute(depots, xy, w, value, tasks, model, lam)
    monkeypatch.setattr(pricing, "WIDE", 1)
    for work in (1, 10, 40, 100, 400, 2_000):
        res = _bound(depots, xy, w, value, lam, tasks, model, max_work=work, plan=True)
        assert res.bound >= ip - 1e-6 >= res.plan_g - 2e-6
        assert res.converged or res.capped == "work"
        assert res.work <= work + 1e-9
    monkeypatch.setattr(pricing, "MAX_PRICED", 2)
    res = _bound(depots, xy, w, value, lam, tasks, model)
    assert res.capped == "requests" and res.labels == 0 and res.bound >= ip - 1e-6


def test_a_class_too_wide_to_price_is_bounded_by_its_knapsack_by_hand(model, monkeypatch):
    """The one-request window by hand: a drone that lands freely, wider than the pricing
    takes, is bounded by its payload's knapsack of the prizes (λ·3: the 1 kg fits), the
    route's energy left out; the true optimum is λ·3 − E."""
    monkeypatch.setattr(pricing, "MAX_PRICED", 0)
    depots = np.array([[0.0, 0.0], [3000.0, 0.0]])
    task = Task(0, -1, np.array([0], dtype=np.int64))
    lam = lam_j(ALPHA, model.usable_j)
    res = _bound(depots, np.array([[1000.0, 0.0]]), np.array([1.0]), [3.0], lam, [task], model)
    assert res.capped == "requests" and res.priced and res.labels == 0
    assert res.bound == pytest.approx(3 * lam, abs=1e-6)
