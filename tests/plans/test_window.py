"""One window of planning: a hand-checked instance and invariants on random ones."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from marops_cli.config import EnergyConfig, PlanConfig
from marops_cli.data.frame import Frame
from marops_cli.energy import EnergyModel, reference_power_w
from marops_cli.errors import RunError
from marops_cli.plans import GreedySelector, MilpSelector, Selector
from marops_cli.plans.objective import lam_j, score_routes
from marops_cli.plans.pool import build_pool
from marops_cli.plans.problem import WindowProblem
from marops_cli.plans.ranges import pick_candidates, range_table
from marops_cli.plans.view import EVERY_DEPOT, FREE
from marops_cli.plans.window import DroneRoute, check_routes, plan_routes
from marops_cli.policies.base import WindowView
from marops_cli.segment.depots import Depots, nearest_candidates

FRAME = Frame(121.47, 31.23, 10.0)
WINDOW_H = 0.5

# docs/method.md §3's per-km table is given to 5 significant figures (±0.0005 kJ/km, at worst
# 3e-5 relative at 15.991 kJ/km), so hand sums from it agree with the model to 1e-4.
HAND_RTOL = 1e-4
# kJ/km with the payload on board (docs/method.md §3)
KJ_PER_KM = {0.0: 15.991, 0.5: 18.091, 1.0: 20.499, 1.5: 23.199, 2.0: 26.179, 2.5: 29.426}


# ---------------------------------------------------------------------------------------
# The hand-checked instance: 2 depots, 2 drones, 5 orders, t = 4, half-hour windows.
#
#   depot 0 (0, 0), depot 1 (2000, 0); candidates [[0, 1], [1, 0]].
#   drone 0 at depot 0, action 0 (come back to 0); drone 1 at depot 1, action 1 (fly to 0).
#   With 2 depots every flight range holds both areas, so both drones see all 5 orders.
#
#   order  xy             kg   due  delay h  v = 1 + delay   day index
#   A      (0, 1000)      2.0  1    1.5      2.5             40
#   B      (2000, 1000)   1.5  2    1.0      2.0             41
#   C      (750, 1000)    1.0  2    1.0      2.0             42
#   D      (-750, 0)      0.5  0    2.0      3.0             43
#   E      (500, -1000)   1.0  5    0.0      1.0             44
#
# Which orders: 6 kg for 2 × 2.5 kg, so at least 1 kg stays behind. α = 0.2 makes
# λ = 4 × 168.75 kJ = 675 kJ per unit of v, more than two full batteries (337.5 kJ):
# the served set maximises Σ v first. Leaving E alone behind (v = 1) is the only way to
# lose less than 2; A..D weigh 5.0 kg and split into 2.5 + 2.5 only as {A, D} + {B, C}.
# Which drone: drone 0 with {A, D} and drone 1 with {B, C} (below) cost 139.07 kJ; the
# swap costs > 200 kJ (drone 0 → B alone is 2236 m at 2.5 kg = 65.8 kJ).
#
# Visiting order and energy (kJ/km from docs/method.md §3, 3-4-5 triangles):
#   drone 0: 0 → A → D → 0:  1000 m @ 2.5 kg + 1250 m @ 0.5 kg + 750 m @ 0 kg
#            = 29.426 + 22.61375 + 11.99325 = 64.0330 kJ
#            (D first, same 3000 m: 750 @ 2.5 + 1250 @ 2.0 + 1000 @ 0 = 70.7845 kJ;
#             the paper's nearest-neighbour order takes D first, 750 m < 1000 m)
#   drone 1: 1 → B → C → 0:  1000 m @ 2.5 kg + 1250 m @ 1.0 kg + 1250 m @ 0 kg
#            = 29.426 + 25.62375 + 19.98875 = 75.0385 kJ
# ---------------------------------------------------------------------------------------
DEPOT_XY = np.array([[0.0, 0.0], [2000.0, 0.0]])
ORDER_XY = np.array([[0, 1000], [2000, 1000], [750, 1000], [-750, 0], [500, -1000]], float)
WEIGHT = np.array([2.0, 1.5, 1.0, 0.5, 1.0])
DUE_W = np.array([1, 2, 2, 0, 5])
DAY_IDX = np.array([40, 41, 42, 43, 44])
A, B, C, D, E = DAY_IDX


def kj(*legs: tuple[float, float]) -> float:
    """Energy in J of (metres, kg on board) legs from docs/method.md §3's per-km table."""
    return sum(m / 1000 * KJ_PER_KM[kg] for m, kg in legs) * 1000


def hand_view() -> WindowView:
    depots = Depots("kmeans", FRAME, DEPOT_XY, np.array([3, 2]), nearest_candidates(DEPOT_XY, 2))
    t = 4
    return WindowView.paper(
        t=t,
        n_windows=16,
        window_h=WINDOW_H,
        depots=depots,
        ranges=range_table(depots, 0.25),
        drone_depot=np.array([0, 1]),
        pending_idx=DAY_IDX,
        pending_xy=ORDER_XY,
        pending_area=depots.assign(ORDER_XY[:, 0], ORDER_XY[:, 1]),
        pending_delay_h=np.maximum(0, t - DUE_W) * WINDOW_H,
        pending_due_w=DUE_W,
        pending_due_s=DUE_W * 1800.0 + 900.0,
        pending_weight=WEIGHT,
    )


@pytest.fixture(scope="module")
def model() -> EnergyModel:
    return EnergyModel()


def test_hand_instance_fixture_is_what_the_comment_says():
    view = hand_view()
    assert view.depots.candidates.tolist() == [[0, 1], [1, 0]]
    assert view.ranges.all()  # 2 depots: every range is the whole map
    assert_allclose(view.pending_delay_h, [1.5, 1.0, 1.0, 2.0, 0.0])
    assert view.pending_area.tolist() == [0, 1, 0, 0, 0]


@pytest.mark.parametrize("backend", ["cvxpy", "highs"])
def test_hand_instance_exact_order(model, backend):
    cfg = PlanConfig(alpha=0.2, planner="subsets")
    plan = plan_routes(hand_view(), np.array([0, 1]), model, cfg, MilpSelector(backend=backend))
    r0, r1 = plan.routes
    assert plan.selection.status == "optimal" and not plan.selection.fallback
    assert plan.n_candidates == 5

    assert (r0.drone, r0.start, r0.action, r0.end) == (0, 0, 0, 0)
    assert r0.stops == (A, D)  # heavy A first, although D is nearer
    assert_allclose(r0.legs_m, [1000, 1250, 750], rtol=1e-12)
    assert_allclose(r0.legs_j, [kj((1000, 2.5)), kj((1250, 0.5)), kj((750, 0.0))], rtol=HAND_RTOL)
    assert_allclose(r0.energy_j, 64_033.0, rtol=HAND_RTOL)
    assert r0.payload_kg == pytest.approx(2.5)

    assert (r1.drone, r1.start, r1.action, r1.end) == (1, 1, 1, 0)
    assert r1.stops == (B, C)
    assert_allclose(r1.legs_m, [1000, 1250, 1250], rtol=1e-12)
    assert_allclose(r1.legs_j, [kj((1000, 2.5)), kj((1250, 1.0)), kj((1250, 0.0))], rtol=HAND_RTOL)
    assert_allclose(r1.energy_j, 75_038.5, rtol=HAND_RTOL)
    assert r1.payload_kg == pytest.approx(2.5)

    # objective: energy flown + λ · v_E for E left behind (λ = 4 × 168 750 J)
    assert_allclose(plan.selection.objective, 64_033.0 + 75_038.5 + 675_000.0, rtol=HAND_RTOL)


def test_hand_instance_greedy_order_is_the_papers(model):
    cfg = PlanConfig(alpha=0.2, ordering="greedy", planner="subsets")
    plan = plan_routes(hand_view(), np.array([0, 1]), model, cfg, MilpSelector())
    r0, r1 = plan.routes
    assert r0.stops == (D, A)  # nearest first: 750 m < 1000 m
    assert_allclose(r0.energy_j, kj((750, 2.5), (1250, 2.0), (1000, 0.0)), rtol=HAND_RTOL)
    assert_allclose(r0.energy_j, 70_784.5, rtol=HAND_RTOL)
    assert r1.stops == (B, C)  # the nearest is also the best here
    assert_allclose(r1.energy_j, 75_038.5, rtol=HAND_RTOL)


def test_hand_instance_global_scope_lands_at_the_nearest_depot(model):
    """OPS-global: plans are ordered for a round trip, then land at the depot nearest the
    last customer. Drone 1's last customer C is 1250 m from depot 0 and 1601 m from depot
    1, so it lands at 0: the same routes as in range scope; actions are ignored."""
    cfg = PlanConfig(alpha=0.2, planner="subsets")
    plan = plan_routes(hand_view(), np.array([1, 0]), model, cfg, MilpSelector(), "global")
    r0, r1 = plan.routes
    assert (r0.start, r0.end, r0.action, r0.stops) == (0, 0, 0, (A, D))
    assert (r1.start, r1.end, r1.action, r1.stops) == (1, 0, 0, (B, C))
    assert_allclose([r0.energy_j, r1.energy_j], [64_033.0, 75_038.5], rtol=HAND_RTOL)


def test_hand_instance_selection_is_the_brute_force_optimum(model):
    """Every way to give each drone an ordered subset: none beats the hand answer."""
    view = hand_view()
    lam = 4 * model.usable_j
    v = 1.0 + view.pending_delay_h
    ends = [0, 0]
    best = np.inf
    for owner in itertools.product([-1, 0, 1], repeat=5):
        total = lam * v[[j for j in range(5) if owner[j] == -1]].sum()
        for u in (0, 1):
            mine = [j for j in range(5) if owner[j] == u]
            if WEIGHT[mine].sum() > 2.5 + 1e-9:
                total = np.inf
                break
            start = DEPOT_XY[u]
            total += min(
                model.route_energy(
                    np.vstack([start, ORDER_XY[list(p)].reshape(-1, 2), DEPOT_XY[ends[u]]]),
                    WEIGHT[list(p)],
                )[1].sum()
                for p in itertools.permutations(mine)
            )
        best = min(best, total)
    plan = plan_routes(
        view, np.array([0, 1]), model, PlanConfig(alpha=0.2, planner="subsets"), MilpSelector()
    )
    assert_allclose(plan.selection.objective, best, rtol=1e-9)


def _without_requests(view: WindowView) -> WindowView:
    for name in ("idx", "xy", "area", "delay_h", "due_w", "due_s", "weight", "stock"):
        arr = getattr(view, f"pending_{name}")
        setattr(view, f"pending_{name}", arr[:0])
    return view


@pytest.mark.parametrize("scope", ["range", "global"])
def test_no_pending_requests(model, scope):
    """Nothing to deliver: drones fly their action's transfer (range) or stay (global)."""
    plan = plan_routes(
        _without_requests(hand_view()), np.array([0, 1]), model, PlanConfig(), MilpSelector(), scope
    )
    assert plan.n_candidates == 0
    assert [r.stops for r in plan.routes] == [(), ()]
    ends = [0, 0] if scope == "range" else [0, 1]
    assert [r.end for r in plan.routes] == ends
    assert plan.routes[0].energy_j == 0.0  # stays put: a row with energy 0 (docs/outputs.md)
    transfer = kj((2000, 0.0)) if scope == "range" else 0.0
    assert_allclose(plan.routes[1].energy_j, transfer, rtol=HAND_RTOL)


def test_destination_out_of_reach_stays_and_plans_in_the_stay_range(model):
    """Depots 12 km apart, beyond the 10.55 km an empty drone flies on 168.75 kJ. The drone
    asked to cross stays (action 0) and takes its candidates from the range of staying
    (its own area), not from the range of the flight it cannot make."""
    xy = np.array([[0.0, 0.0], [12_000.0, 0.0]])
    depots = Depots("kmeans", FRAME, xy, np.array([1, 1]), nearest_candidates(xy, 2))
    ranges = np.zeros((2, 2, 2), dtype=bool)
    ranges[:, 0] = np.eye(2, dtype=bool)  # staying: the own area only
    ranges[:, 1] = True  # crossing: both areas
    req_xy = np.array([[11_000.0, 0.0], [0.0, 1000.0]])  # area 1 (late), area 0 (on time)
    view = WindowView.paper(
        t=3,
        n_windows=16,
        window_h=WINDOW_H,
        depots=depots,
        ranges=ranges,
        drone_depot=np.array([0]),
        pending_idx=np.array([7, 9]),
        pending_xy=req_xy,
        pending_area=depots.assign(req_xy[:, 0], req_xy[:, 1]),
        pending_delay_h=np.array([1.5, 0.0]),
        pending_due_w=np.array([0, 3]),
        pending_due_s=np.array([900.0, 6300.0]),
        pending_weight=np.array([1.0, 1.0]),
    )
    assert view.pending_area.tolist() == [1, 0]
    plan = plan_routes(
        view, np.array([1]), model, PlanConfig(max_parcels=1, planner="subsets"), MilpSelector()
    )
    (r,) = plan.routes
    assert (r.action, r.end, r.stops) == (0, 0, (9,))
    assert_allclose(r.energy_j, kj((1000, 1.0), (1000, 0.0)), rtol=HAND_RTOL)


def test_check_routes_rejects_broken_routes(model):
    def route(drone, stops, kg, joules):
        legs = np.full(len(stops) + 1, joules / (len(stops) + 1))
        return DroneRoute(drone, 0, 0, 0, stops, legs, legs, kg)

    check_routes([route(0, (1, 2), 2.5, 100_000.0), route(1, (3,), 0.1, 1.0)], model)
    with pytest.raises(RunError, match="payload"):
        check_routes([route(0, (1,), 2.6, 1.0)], model)
    with pytest.raises(RunError, match="usable battery"):
        check_routes([route(0, (1,), 1.0, model.usable_j + 1.0)], model)
    with pytest.raises(RunError, match="twice"):
        check_routes([route(0, (1,), 1.0, 1.0), route(1, (1,), 1.0, 1.0)], model)


# ---------------------------------------------------------------------------------------
# Random instances
# ---------------------------------------------------------------------------------------
_REF_CFG = EnergyConfig()
_REF_POWER: dict[float, float] = {}


def reference_energy_j(legs_m: np.ndarray, weights: np.ndarray) -> float:
    """Route energy with the exact (root-finding) power model, no lookup table."""
    on_board = np.append(np.cumsum(weights[::-1])[::-1], 0.0)  # eq. (6)
    total = 0.0
    for d, w in zip(legs_m, on_board, strict=True):
        key = round(float(w), 9)
        if key not in _REF_POWER:
            _REF_POWER[key] = reference_power_w(key, _REF_CFG)
        total += _REF_POWER[key] * float(d) / _REF_CFG.speed_ms
    return total


@st.composite
def instances(draw):
    """A random window: depots in a square (sometimes too big to cross on one battery),
    drones at random depots with random actions, random pending requests."""
    seed = draw(st.integers(0, 2**32 - 1))
    n_dep = draw(st.integers(2, 6))
    n_drones = draw(st.integers(1, 4))
    n_req = draw(st.integers(0, 30))
    side_m = draw(st.sampled_from([1500.0, 5000.0, 14000.0]))
    n_actions = draw(st.integers(1, 4))
    coverage = draw(st.sampled_from([0.1, 0.25, 0.5, 1.0]))
    m_hat = draw(st.integers(1, 6))
    scope = draw(st.sampled_from(["range", "global"]))
    ordering = draw(st.sampled_from(["exact", "greedy"]))
    selector = draw(st.sampled_from(["cvxpy", "highs", "greedy"]))
    mode = draw(st.sampled_from(["top", "draft"]))
    ties = draw(st.sampled_from(["nearest", "due"]))
    # few distinct due times: many ties on (delay, due time), broken by distance
    coarse_due = draw(st.booleans())
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, side_m, (n_dep, 2))
    depots = Depots(
        "kmeans", FRAME, xy, np.zeros(n_dep, np.int64), nearest_candidates(xy, n_actions)
    )
    t = int(rng.integers(0, 16))
    req_xy = rng.uniform(0, side_m, (n_req, 2))
    due_w = rng.integers(0, 2 if coarse_due else 16, n_req)
    view = WindowView.paper(
        t=t,
        n_windows=16,
        window_h=WINDOW_H,
        depots=depots,
        ranges=range_table(depots, coverage),
        drone_depot=rng.integers(0, n_dep, n_drones),
        pending_idx=np.sort(rng.choice(1000, n_req, replace=False)),
        pending_xy=req_xy,
        pending_area=depots.assign(req_xy[:, 0], req_xy[:, 1]),
        pending_delay_h=np.maximum(0, t - due_w) * WINDOW_H,
        pending_due_w=due_w,
        pending_due_s=due_w * 1800.0
        + (np.full(n_req, 900.0) if coarse_due else rng.uniform(0, 1800, n_req)),
        pending_weight=rng.uniform(0.1, 2.5, n_req),
        ties=ties,
    )
    actions = rng.integers(0, depots.candidates.shape[1], n_drones)
    cfg = PlanConfig(
        planner="subsets",
        max_parcels=m_hat,
        ordering=ordering,
        alpha=float(rng.uniform(0.1, 1.0)),
        candidates=mode,
        ties=ties,
    )
    return view, actions, cfg, scope, selector


def _selector(name: str) -> Selector:
    return GreedySelector() if name == "greedy" else MilpSelector(backend=name)


def preferences(view: WindowView, u: int, action: int, m_hat: int, scope: str) -> list:
    """Drone u's requests in order of preference (pending positions), docs/method.md §4 / §7,
    with equally delayed requests ordered as ``view.ties`` says."""
    s = int(view.drone_depot[u])
    sxy = view.depots.xy[s]
    dist = np.hypot(*(view.pending_xy - sxy).T)
    if scope == "range":
        inside = [
            p for p in range(view.pending_idx.size) if view.ranges[s, action][view.pending_area[p]]
        ]
        # equally delayed: nearer first, then earlier due ("nearest"), or the reverse ("due")
        near, due = dist, view.pending_due_s
        if view.ties == "due":
            near, due = due, near
        return sorted(inside, key=lambda p: (-view.pending_delay_h[p], near[p], due[p], p))
    pool = sorted(
        range(view.pending_idx.size),
        key=lambda p: (-view.pending_delay_h[p], view.pending_due_s[p], p),
    )[: view.n_drones * m_hat]
    return sorted(pool, key=lambda p: (dist[p], p))


def expected_candidates(view: WindowView, acts: list, m_hat: int, scope: str, mode: str) -> list:
    """Every drone's Ĉ_u, written independently of the planner."""
    prefs = [preferences(view, u, a, m_hat, scope) for u, a in enumerate(acts)]
    if mode == "top":
        return [p[:m_hat] for p in prefs]
    picks: list[list] = [[] for _ in prefs]
    claimed: set = set()
    for rnd in range(m_hat):  # snake draft
        order = list(range(len(prefs)))
        for u in order if rnd % 2 == 0 else order[::-1]:
            free = [q for q in prefs[u] if q not in claimed]
            if free:
                picks[u].append(free[0])
                claimed.add(free[0])
    return [
        mine + [q for q in pref if q not in mine][: m_hat - len(mine)]
        for mine, pref in zip(picks, prefs, strict=True)
    ]


@settings(max_examples=60, deadline=None)
@given(instances())
def test_window_invariants(model, inst):
    view, actions, cfg, scope, sel_name = inst
    plan = plan_routes(view, actions, model, cfg, _selector(sel_name), scope)
    dep = view.depots
    pos = {int(i): p for p, i in enumerate(view.pending_idx)}  # day index -> pending position
    assert plan.t == view.t
    assert [r.drone for r in plan.routes] == list(range(view.n_drones))
    assert not plan.selection.fallback

    served: list[int] = []
    energy_total = 0.0
    candidates: set[int] = set()
    acts = [r.action for r in plan.routes]
    expected = expected_candidates(view, acts, cfg.max_parcels, scope, cfg.candidates)
    for u, r in enumerate(plan.routes):
        s = int(view.drone_depot[u])
        p = [pos[i] for i in r.stops]
        w = view.pending_weight[p]
        served += list(r.stops)
        energy_total += r.energy_j

        # starts at its depot, ends where the rule says
        assert r.start == s
        if scope == "range":
            assert r.end == dep.candidates[s, r.action]
            if r.action != actions[u]:  # only to stay, when the destination is out of reach
                assert r.action == 0
                far = dep.xy[dep.candidates[s, actions[u]]] - dep.xy[s]
                assert np.hypot(*far) * model.energy_per_m(0.0) > model.usable_j
        else:
            assert r.action == 0
            if p:
                d = np.hypot(*(dep.xy - view.pending_xy[p[-1]]).T)
                assert r.end == int(np.argmin(d))
            else:
                assert r.end == s

        # the drone's requests are among its candidates (and so inside its flight range)
        cand = expected[u]
        candidates.update(cand)
        assert set(p) <= set(cand)
        assert len(p) <= cfg.max_parcels
        if scope == "range":
            assert all(view.ranges[s, r.action][view.pending_area[q]] for q in p)

        # payload and battery
        assert r.payload_kg == pytest.approx(w.sum(), abs=1e-12)
        assert r.payload_kg <= model.max_payload_kg + 1e-9
        assert r.energy_j <= model.usable_j + 1e-6

        # legs: the geometry of start -> stops -> end, and they sum to the route
        pts = np.vstack([dep.xy[r.start], view.pending_xy[p].reshape(-1, 2), dep.xy[r.end]])
        assert len(r.legs_m) == len(r.legs_j) == len(p) + 1
        assert_allclose(r.legs_m, np.hypot(*np.diff(pts, axis=0).T), rtol=1e-12, atol=1e-9)
        assert_allclose(r.legs_j.sum(), r.energy_j, rtol=1e-12, atol=1e-9)
        assert_allclose(r.legs_m.sum(), r.distance_m, rtol=1e-12, atol=1e-9)
        # the exact (root-finding) power model agrees within 0.1 %
        assert_allclose(r.energy_j, reference_energy_j(r.legs_m, w), rtol=1e-3, atol=1e-6)

    assert len(served) == len(set(served)), "an order is served twice"
    assert plan.n_candidates == len(candidates)
    # objective = energy flown + λ Σ v over the candidates left behind
    lam = (1 - cfg.alpha) / cfg.alpha * model.usable_j
    left = [c for c in candidates if int(view.pending_idx[c]) not in set(served)]
    expect = energy_total + lam * sum(1.0 + view.pending_delay_h[c] for c in left)
    assert_allclose(plan.selection.objective, expect, rtol=1e-9, atol=1e-6)
    assert set(plan.timings) >= {"candidates", "plans", "build", "solve", "total"}


def test_draft_by_hand() -> None:
    """Two drones want the same three requests most: they alternate, snake order."""
    from marops_cli.plans.candidates import draft

    prefs = [np.array([0, 1, 2, 3]), np.array([0, 1, 2, 4])]
    got = draft(prefs, 5, 2)
    # round 1: drone 0 takes 0, drone 1 takes 1; round 2 (backwards): drone 1 takes 2,
    # drone 0 takes 3.
    assert [g.tolist() for g in got] == [[0, 3], [1, 2]]
    # A drone whose range holds only claimed requests tops up with them.
    got = draft([np.array([0, 1]), np.array([0])], 2, 2)
    assert [g.tolist() for g in got] == [[0, 1], [0]]


def test_candidate_ties_by_hand() -> None:
    # Delay counts whole windows, so 10, 11 and 12 tie on it; 13 is the most delayed.
    idx = np.array([10, 11, 12, 13])
    delay = np.array([1.0, 1.0, 1.0, 2.0])
    due_s = np.array([100.0, 200.0, 300.0, 50.0])
    dist = np.array([900.0, 300.0, 300.0, 5000.0])
    # nearest: 11 and 12 are nearer than 10; between them 11 is due first
    assert pick_candidates(idx, delay, due_s, dist, 3, "nearest").tolist() == [13, 11, 12]
    # due (docs/method.md §4's literal rule): 10 and 11 are due first, whatever the distance
    assert pick_candidates(idx, delay, due_s, dist, 3, "due").tolist() == [13, 10, 11]
    # fewer requests than M̂: all of them, still in order
    assert pick_candidates(idx, delay, due_s, dist, 9, "nearest").tolist() == [13, 11, 12, 10]


# ---------------------------------------------------------------------------------------
# The route pool (the default planner)
# ---------------------------------------------------------------------------------------


def test_pool_finds_the_hand_optimum(model):
    """On the hand instance the pool reaches the brute-force optimum: the same routes,
    order and energies as the hand answer above."""
    plan = plan_routes(hand_view(), np.array([0, 1]), model, PlanConfig(alpha=0.2), MilpSelector())
    r0, r1 = plan.routes
    assert (r0.start, r0.end, r0.stops) == (0, 0, (A, D))
    assert (r1.start, r1.end, r1.stops) == (1, 0, (B, C))
    assert_allclose([r0.energy_j, r1.energy_j], [64_033.0, 75_038.5], rtol=HAND_RTOL)
    score = score_routes(
        hand_view().pending_idx,
        hand_view().pending_delay_h,
        [(r.stops, r.energy_j) for r in plan.routes],
        lam_j(0.2, model.usable_j),
    )
    assert_allclose(score.J, 64_033.0 + 75_038.5 + 675_000.0, rtol=HAND_RTOL)


def test_pool_landing_nearest_by_hand(model):
    """Landing nearest the last customer: drone 1 ends its {B, C} route at depot 0 (C is
    1250 m from depot 0, 1601 m from depot 1) whatever its action says."""
    cfg = PlanConfig(alpha=0.2, landing="nearest")
    plan = plan_routes(hand_view(), np.array([0, 0]), model, cfg, MilpSelector())
    assert [(r.stops, r.end) for r in plan.routes] == [((A, D), 0), ((B, C), 0)]


def test_free_action_lands_nearest_with_the_pool_and_stays_with_subsets(model):
    """FREE (-1) is the free landing: with destination landing configured, drone 1 still
    ends its {B, C} route at depot 0, nearest C; the paper's planner flies it as stay."""
    cfg = PlanConfig(alpha=0.2)
    plan = plan_routes(hand_view(), np.array([0, FREE]), model, cfg, MilpSelector())
    assert [(r.stops, r.end, r.action) for r in plan.routes] == [
        ((A, D), 0, 0),
        ((B, C), 0, FREE),
    ]
    subsets = cfg.model_copy(update={"planner": "subsets"})
    plan = plan_routes(hand_view(), np.array([0, FREE]), model, subsets, MilpSelector())
    assert [(r.end, r.action) for r in plan.routes] == [(0, 0), (1, 0)]


@st.composite
def pool_instances(draw):
    """Random windows for the pool: heavy parcels near the payload limit, tiny
    batteries, a single depot, many drones."""
    seed = draw(st.integers(0, 2**32 - 1))
    n_dep = draw(st.integers(1, 6))
    n_drones = draw(st.sampled_from([1, 2, 3, 8, 20]))
    n_req = draw(st.integers(0, 60))
    side_m = draw(st.sampled_from([1500.0, 5000.0, 14000.0]))
    weights = draw(st.sampled_from(["uniform", "heavy", "light"]))
    battery = draw(st.sampled_from([225_000.0, 60_000.0, 12_000.0]))
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, side_m, (n_dep, 2))
    n_actions = draw(st.integers(1, 4))
    depots = Depots(
        "kmeans", FRAME, xy, np.zeros(n_dep, np.int64), nearest_candidates(xy, n_actions)
    )
    t = int(rng.integers(0, 16))
    one_spot = draw(st.booleans())
    req_xy = (
        np.repeat(rng.uniform(0, side_m, (1, 2)), n_req, axis=0)
        if one_spot
        else rng.uniform(0, side_m, (n_req, 2))
    )
    low, high = {"uniform": (0.1, 2.5), "heavy": (2.2, 2.5), "light": (0.05, 0.3)}[weights]
    due_w = rng.integers(0, 16, n_req)
    view = WindowView.paper(
        t=t,
        n_windows=16,
        window_h=WINDOW_H,
        depots=depots,
        ranges=range_table(depots, draw(st.sampled_from([0.25, 1.0]))),
        drone_depot=rng.integers(0, n_dep, n_drones),
        pending_idx=np.sort(rng.choice(1000, n_req, replace=False)),
        pending_xy=req_xy,
        pending_area=depots.assign(req_xy[:, 0], req_xy[:, 1]),
        pending_delay_h=np.maximum(0, t - due_w) * WINDOW_H,
        pending_due_w=due_w,
        pending_due_s=due_w * 1800.0 + 900.0,
        pending_weight=rng.uniform(low, high, n_req),
    )
    # -1 is FREE, the free landing (docs/method.md §4.1), drawn in half the instances.
    actions = rng.integers(-1 if draw(st.booleans()) else 0, depots.candidates.shape[1], n_drones)
    cfg = PlanConfig(
        alpha=float(rng.uniform(0.1, 1.0)),
        landing=draw(st.sampled_from(["destination", "nearest"])),
        range=draw(st.sampled_from(["reach", "areas"])),
        pool_candidates=draw(st.sampled_from([3, 10, 80])),
        pool_iterations=draw(st.sampled_from([0, 5, 40])),
        pool_urgency=draw(st.sampled_from([0.0, 1.0])),
        pack_price=draw(st.sampled_from([0.0, 1.0])),
        serve_h=draw(st.sampled_from([0.0, 0.75])),
    )
    scope = draw(st.sampled_from(["range", "global"]))
    selector = draw(st.sampled_from(["cvxpy", "highs", "greedy"]))
    model = EnergyModel(EnergyConfig(battery_j=battery))
    if draw(st.booleans()):  # a mixed fleet: a light type beside the drawn one
        light = EnergyModel(EnergyConfig(battery_j=battery / 2, max_payload_kg=1.0, speed_ms=14.0))
        view.drone_models = tuple(light if k else model for k in rng.integers(0, 2, n_drones))
    return view, actions, cfg, scope, selector, model


@pytest.mark.parametrize("urgency", [0.0, 1.0])
def test_pool_urgency_prefers_the_request_already_due(model, urgency):
    """One drone, two 2.0 kg parcels (only one fits), neither delayed yet: P at (-900, 0)
    is due in two windows, Q at (0, -1000) is due now. Without the bonus the drone takes P,
    100 m nearer (2 x 100 m at 2.0 kg and empty cost about 4.2 kJ less); with one window of
    urgency Q is worth λ · 0.5 h more (84.4 kJ at α 0.5) and wins. The bonus steers how
    routes are built (construction and exchange here); ruin and recreate, whose refills
    are blurred, may also meet the route to P, and the selection judges by G alone."""
    view = hand_view()
    view.drone_depot = np.array([0])
    view.pending_idx = np.array([7, 8])
    view.pending_xy = np.array([[-900.0, 0.0], [0.0, -1000.0]])
    view.pending_area = np.array([0, 0])
    view.pending_delay_h = np.zeros(2)
    view.pending_due_w = np.array([view.t + 2, view.t])
    view.pending_due_s = view.pending_due_w * 1800.0
    view.pending_weight = np.array([2.0, 2.0])
    view.pending_stock = np.full(2, EVERY_DEPOT)
    view.drone_models, view.drone_ready = (model,), np.ones(1, bool)
    cfg = PlanConfig(alpha=0.5, pool_urgency=urgency, pool_iterations=0)
    (r,) = plan_routes(view, np.array([0]), model, cfg, MilpSelector()).routes
    assert r.stops == ((7,) if urgency == 0 else (8,))
    assert (r.start, r.end) == (0, 0)
    legs = [(900.0, 2.0), (900.0, 0.0)] if urgency == 0 else [(1000.0, 2.0), (1000.0, 0.0)]
    assert_allclose(r.energy_j, kj(*legs), rtol=HAND_RTOL)


@settings(max_examples=80, deadline=None)
@given(pool_instances())
def test_pool_routes_never_break_payload_battery_or_one_visit(inst):
    view, actions, cfg, scope, sel_name, model = inst
    plan = plan_routes(view, actions, model, cfg, _selector(sel_name), scope)
    dep = view.depots
    pos = {int(i): p for p, i in enumerate(view.pending_idx)}
    assert [r.drone for r in plan.routes] == list(range(view.n_drones))
    served: list[int] = []
    for u, r in enumerate(plan.routes):
        own = model if view.drone_models is None else view.drone_models[u]
        s = int(view.drone_depot[u])
        p = [pos[i] for i in r.stops]  # every stop is a pending request
        served += list(r.stops)
        assert r.start == s
        if scope == "range" and cfg.landing == "destination" and r.action != FREE:
            assert r.end == dep.candidates[s, r.action]
        elif p:  # lands at the depot nearest the last customer
            d = np.hypot(*(dep.xy - view.pending_xy[p[-1]]).T)
            assert d[r.end] == pytest.approx(d.min(), abs=1e-9)
        else:  # nothing to deliver and free to land: it stays
            assert r.end == s
        if scope == "range" and cfg.range == "areas":
            a = 0 if r.action == FREE else r.action  # a free drone serves its stay range
            assert all(view.ranges[s, a][view.pending_area[q]] for q in p)
        w = view.pending_weight[p]
        assert r.payload_kg == pytest.approx(w.sum(), abs=1e-12)
        assert r.payload_kg <= own.max_payload_kg + 1e-9  # its own type's limits
        assert r.energy_j <= own.usable_j + 1e-6
        pts = np.vstack([dep.xy[r.start], view.pending_xy[p].reshape(-1, 2), dep.xy[r.end]])
        legs_m, legs_j = own.route_energy(pts, w)
        assert_allclose(r.legs_m, legs_m, rtol=1e-12, atol=1e-9)
        assert_allclose(r.legs_j, legs_j, rtol=1e-12, atol=1e-9)
    assert len(served) == len(set(served)), "an order is served twice"
    # The selection over the pool is never worse than the best single conflict-free
    # solution the pool was built from (re-ordering for energy only adds to G).
    # Both are judged by the delay the planner prices (the credit, the night: the same
    # for both), which the selection maximises.
    lam = lam_j(cfg.alpha, model.usable_j)
    problem = WindowProblem.of(view, np.array([r.action for r in plan.routes]), model, cfg, scope)
    assert problem.lam == lam
    score = score_routes(
        view.pending_idx, problem.priced_h, [(r.stops, r.energy_j) for r in plan.routes], lam
    )
    # (the pool's best is scored with the urgency bonus when there is one, G without,
    # and with the packing price's energies when there is one, the exact ones without)
    if (
        sel_name != "greedy"
        and cfg.pool_urgency == 0
        and cfg.pack_price == 0
        and cfg.planner == "pool"
    ):
        best = build_pool(
            problem,
            n_candidates=cfg.pool_candidates,
            iterations=cfg.pool_iterations,
            seed=view.t,
        ).best_g
        assert best - 1e-6 * max(1.0, abs(best)) <= score.G


def _busy_view(
    seed: int, n: int, span_m: tuple[float, float], kg: tuple[float, float]
) -> WindowView:
    """The hand instance's map and drones with ``n`` random requests, all due, delayed
    0-1.5 h, within ``span_m`` on both axes and weighing within ``kg``."""
    rng = np.random.default_rng(seed)
    view = hand_view()
    view.pending_xy = rng.uniform(*span_m, (n, 2))
    view.pending_idx = np.arange(n)
    view.pending_area = view.depots.assign(view.pending_xy[:, 0], view.pending_xy[:, 1])
    view.pending_delay_h = rng.integers(0, 4, n) * WINDOW_H
    view.pending_due_w = np.zeros(n, dtype=np.int64)
    view.pending_due_s = np.zeros(n)
    view.pending_weight = rng.uniform(*kg, n)
    view.pending_stock = np.full(n, EVERY_DEPOT)
    return view


@pytest.mark.parametrize("scope", ["range", "global"])
def test_pool_is_deterministic(model, scope):
    view = _busy_view(5, 40, (-1000, 3000), (0.1, 1.0))
    plans = [
        plan_routes(view, np.array([0, 1]), model, PlanConfig(), MilpSelector(), scope)
        for _ in range(2)
    ]
    a, b = ([(r.stops, r.end, r.energy_j) for r in p.routes] for p in plans)
    assert a == b
    assert sum(len(s) for s, _, _ in a) > 4  # a real plan, not two empty routes


@pytest.mark.parametrize("planner", ["pool", "subsets"])
@pytest.mark.parametrize("scope", ["range", "global"])
def test_mixed_fleet_routes_keep_each_drones_own_limits(scope, planner):
    """A light drone (1 kg, a quarter of the battery) beside heavy ones on a busy window
    of 1-2.4 kg parcels: it carries at most 1 kg and stays within its own battery, while
    the heavy drones carry what it cannot; both planners, both scopes."""
    view = _busy_view(3, 30, (-1500, 3500), (0.3, 2.4))
    view.drone_depot, view.drone_ready = np.array([0, 1, 0, 1]), np.ones(4, bool)
    heavy = EnergyModel()
    light = EnergyModel(EnergyConfig(max_payload_kg=1.0, battery_j=56_250.0, speed_ms=14.0))
    view.drone_models = (light, heavy, light, heavy)
    cfg = PlanConfig(planner=planner)
    plan = plan_routes(view, np.array([0, 1, FREE, 0]), heavy, cfg, MilpSelector(), scope)
    for r, own in zip(plan.routes, view.drone_models, strict=True):
        assert r.payload_kg <= own.max_payload_kg + 1e-9
        assert r.energy_j <= own.usable_j + 1e-6
        pts = np.vstack(
            [view.depots.xy[r.start], view.pending_xy[list(r.stops)].reshape(-1, 2)]
            + [view.depots.xy[r.end]]
        )
        assert_allclose(r.legs_j, own.route_energy(pts, view.pending_weight[list(r.stops)])[1])
    light_kg = [r.payload_kg for r in plan.routes[::2]]
    heavy_kg = [r.payload_kg for r in plan.routes[1::2]]
    assert max(light_kg) <= 1.0 + 1e-9 < max(heavy_kg)
    # The same window with every drone heavy plans differently: the types matter.
    view.drone_models = (heavy,) * 4
    same = plan_routes(view, np.array([0, 1, FREE, 0]), heavy, cfg, MilpSelector(), scope)
    assert [r.stops for r in same.routes] != [r.stops for r in plan.routes]
