"""Plan selection: MILP (cvxpy and highspy) against brute force, greedy, fallbacks."""

from __future__ import annotations

import itertools

import highspy
import numpy as np
import pytest
from numpy.testing import assert_allclose

from marops_cli.config import PlanConfig
from marops_cli.energy import EnergyModel
from marops_cli.plans import (
    Candidates,
    GreedySelector,
    MilpSelector,
    PlanSet,
    SelectionProblem,
    SelectionResult,
    SelectionStatus,
    Selector,
    build_plans,
    greedy_select,
    make_selector,
    solve_highs_direct,
)
from marops_cli.plans import branch as branch_mod
from marops_cli.plans import select as select_mod
from marops_cli.plans.select import SolveVerdict

E_REF = 168_750.0
OBJ_RTOL = 1e-9  # the MILP is solved to a relative gap of 1e-7 of O(1) scaled costs


def plan_set(ids, members, energy) -> PlanSet:
    """A hand-made plan set (plan 0 must be empty); orders follow member positions."""
    members = np.asarray(members, dtype=bool).reshape(len(energy), len(ids))
    order = np.full(members.shape, -1, dtype=np.int8)
    for k, row in enumerate(members):
        stops = np.flatnonzero(row)
        order[k, : stops.size] = stops
    zeros = np.zeros(len(energy))
    return PlanSet(np.asarray(ids), members, order, np.asarray(energy, float), zeros, zeros)


def random_problem(seed: int, drones: int = 3, max_plans: int = 8, alpha: float = 0.5):
    """Drones with overlapping candidate sets and random plans over them."""
    rng = np.random.default_rng(seed)
    pool = 6
    delay = {i: float(rng.uniform(0, 3)) for i in range(pool)}
    sets = []
    for _ in range(drones):
        ids = np.sort(rng.choice(pool, 4, replace=False))
        k = int(rng.integers(2, max_plans + 1))
        members = np.vstack([np.zeros(4, bool), rng.random((k - 1, 4)) < 0.45])
        # the empty plan is the cheapest, as with real routes (triangle inequality)
        energy = rng.uniform(10_000, 30_000) + rng.uniform(0, 30_000, k) * (members.sum(axis=1) > 0)
        energy += 15_000 * members.sum(axis=1)
        sets.append(plan_set(ids, members, energy))
    return SelectionProblem.from_plan_sets(sets, delay, alpha=alpha, energy_ref_j=E_REF)


def brute_force(problem: SelectionProblem, strict: bool = False) -> float:
    best = np.inf
    sizes = np.diff(problem.offsets)
    for chosen in itertools.product(*(range(int(s)) for s in sizes)):
        chosen = np.array(chosen)
        if problem.violation(chosen) is not None:
            continue
        if strict and problem.served(chosen).min(initial=1) < 1:
            continue
        best = min(best, problem.objective(chosen))
    return best


def assert_valid(problem: SelectionProblem, result: SelectionResult) -> None:
    assert result.chosen.shape == (problem.n_drones,)
    assert problem.violation(result.chosen) is None
    assert_allclose(result.objective, problem.objective(result.chosen), rtol=1e-12)


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("backend", ["cvxpy", "highs"])
def test_milp_matches_brute_force(seed, backend):
    problem = random_problem(seed)
    result = MilpSelector(backend=backend).select(problem)
    assert_valid(problem, result)
    assert not result.fallback and result.status == "optimal"
    assert_allclose(result.objective, brute_force(problem), rtol=OBJ_RTOL)


@pytest.mark.parametrize("alpha", [0.2, 0.5, 0.9, 1.0])
def test_milp_matches_brute_force_across_alpha(alpha):
    problem = random_problem(99, alpha=alpha)
    result = MilpSelector().select(problem)
    assert_allclose(result.objective, brute_force(problem), rtol=OBJ_RTOL)
    if alpha == 1.0:  # λ = 0: energy only, every drone flies its cheapest (empty) plan
        assert np.all(result.chosen == 0)


def real_window(seed: int, drones: int = 8):
    model = EnergyModel()
    rng = np.random.default_rng(seed)
    pool = 4 * drones
    xy = rng.uniform(0, 4000, (pool, 2))
    weight = np.clip(rng.lognormal(np.log(0.5), 0.6, pool), 0.1, 2.5)
    delay = {i: float(rng.uniform(0, 3)) for i in range(pool)}
    sets = []
    for _ in range(drones):
        ids = rng.choice(pool, 5, replace=False)
        start, end = rng.uniform(1000, 3000, (2, 2))
        own = Candidates(xy[ids], weight[ids], ids)
        sets.append(build_plans(start, end, own, model, PlanConfig()))
    return SelectionProblem.from_plan_sets(sets, delay, alpha=0.5, energy_ref_j=model.usable_j)


@pytest.mark.parametrize("seed", range(3))
def test_cvxpy_equals_direct_highspy_on_a_window(seed):
    problem = real_window(seed)
    via_cvxpy = MilpSelector(backend="cvxpy").select(problem)
    direct = solve_highs_direct(problem)
    assert_valid(problem, via_cvxpy)
    assert_valid(problem, direct)
    assert_allclose(via_cvxpy.objective, direct.objective, rtol=OBJ_RTOL)
    assert via_cvxpy.build_s > 0 and via_cvxpy.solve_s > 0


@pytest.mark.parametrize("seed", range(20))
def test_greedy_is_feasible_and_never_beats_the_optimum(seed):
    problem = random_problem(seed, drones=4)
    greedy = GreedySelector().select(problem)
    assert_valid(problem, greedy)
    assert greedy.status == "greedy" and not greedy.fallback
    assert greedy.objective >= MilpSelector().select(problem).objective * (1 - 1e-12)


def test_greedy_takes_the_best_gain_first():
    # one request, two drones: drone 1 serves it cheaper, so it gets it
    a = plan_set([7], [[0], [1]], [10_000.0, 30_000.0])
    b = plan_set([7], [[0], [1]], [10_000.0, 20_000.0])
    problem = SelectionProblem.from_plan_sets([a, b], {7: 1.0}, alpha=0.5, energy_ref_j=E_REF)
    assert list(greedy_select(problem)) == [0, 1]


def strict_instance(feasible: bool) -> SelectionProblem:
    # requests 1, 2, 3; drone a flies {1, 2} (or {1}), drone b flies {2, 3} (or {3}).
    # Without the single-order plans, covering 1 and 3 serves 2 twice: infeasible.
    n_plans = 3 if feasible else 2
    a = plan_set(
        [1, 2], [[0, 0], [1, 1], [1, 0]][:n_plans], [10_000.0, 30_000.0, 20_000.0][:n_plans]
    )
    b = plan_set(
        [2, 3], [[0, 0], [1, 1], [0, 1]][:n_plans], [10_000.0, 30_000.0, 20_000.0][:n_plans]
    )
    # α = 1: λ = 0, so the relaxed program serves nothing; strict must serve everything
    return SelectionProblem.from_plan_sets(
        [a, b], {1: 0.0, 2: 0.0, 3: 0.0}, alpha=1.0, energy_ref_j=E_REF
    )


@pytest.mark.parametrize("backend", ["cvxpy", "highs"])
def test_strict_cover_when_feasible(backend):
    problem = strict_instance(feasible=True)
    relaxed = MilpSelector(backend=backend).select(problem)
    assert list(relaxed.chosen) == [0, 0]
    strict = MilpSelector(strict_cover=True, backend=backend).select(problem)
    assert strict.status_text == "strict cover: optimal" and not strict.fallback
    assert np.all(problem.served(strict.chosen) == 1)
    assert_allclose(strict.objective, brute_force(problem, strict=True), rtol=OBJ_RTOL)
    assert_allclose(strict.objective, 50_000.0)  # {1,2} + {3} (or {1} + {2,3})


@pytest.mark.parametrize("backend", ["cvxpy", "highs"])
def test_strict_cover_infeasible_falls_back_to_the_relaxed_program(backend):
    problem = strict_instance(feasible=False)
    result = MilpSelector(strict_cover=True, backend=backend).select(problem)
    assert result.status_text == "strict cover infeasible; relaxed: optimal"
    assert not result.fallback
    assert_allclose(result.objective, brute_force(problem), rtol=OBJ_RTOL)


def test_strict_cover_with_a_request_no_plan_serves():
    a = plan_set([1, 2], [[0, 0], [1, 0]], [10_000.0, 20_000.0])
    problem = SelectionProblem.from_plan_sets([a], {1: 1.0, 2: 1.0}, alpha=0.5, energy_ref_j=E_REF)
    result = MilpSelector(strict_cover=True).select(problem)
    assert result.status_text.startswith("strict cover infeasible (in no plan: [2]); relaxed: ")
    assert list(result.chosen) == [1]


def test_only_empty_plans_needs_no_solver(monkeypatch):
    monkeypatch.setitem(select_mod._BACKENDS, "highs", None)  # would fail if called
    a = plan_set([], np.zeros((1, 0)), [12_000.0])
    problem = SelectionProblem.from_plan_sets([a, a], {}, alpha=0.5, energy_ref_j=E_REF)
    result = MilpSelector().select(problem)
    assert list(result.chosen) == [0, 0] and result.status == "optimal"
    assert_allclose(result.objective, 24_000.0)


@pytest.mark.parametrize("backend", ["cvxpy", "highs"])
def test_solver_error_falls_back_to_greedy(monkeypatch, backend):
    def boom(self):
        raise RuntimeError("HiGHS crashed")

    monkeypatch.setattr(highspy.Highs, "run", boom)
    problem = random_problem(3)
    result = MilpSelector(backend=backend).select(problem)
    assert result.fallback
    assert "solver error" in result.status_text and result.status_text.endswith("fallback: greedy")
    assert_valid(problem, result)
    assert list(result.chosen) == list(greedy_select(problem))


def test_time_limit_without_incumbent_falls_back(monkeypatch):
    def timed_out(milp, strict, limit):
        return select_mod._Attempt(None, "kTimeLimit", 0.001, 0.002)

    monkeypatch.setitem(select_mod._BACKENDS, "highs", timed_out)
    problem = random_problem(4)
    result = MilpSelector().select(problem)
    assert result.fallback and result.status_text == "time limit; fallback: greedy"
    assert_valid(problem, result)


def test_a_solution_that_does_not_verify_is_rejected(monkeypatch):
    def all_ones(milp, strict, limit):  # every plan at once: not a selection
        return select_mod._Attempt(np.ones(milp.cols.size), "kOptimal", 0.0, 0.0)

    monkeypatch.setitem(select_mod._BACKENDS, "highs", all_ones)
    problem = random_problem(5)
    result = MilpSelector().select(problem)
    assert result.fallback and "not a selection" in result.status_text
    assert_valid(problem, result)


def test_time_limit_reaches_highs_through_cvxpy(monkeypatch):
    from cvxpy.reductions.solvers.conic_solvers.highs_conif import HIGHS

    seen = {}
    original = HIGHS.solve_via_data

    def spy(self, data, warm_start, verbose, solver_opts, solver_cache=None):
        seen.update(solver_opts)
        return original(self, data, warm_start, verbose, solver_opts, solver_cache)

    monkeypatch.setattr(HIGHS, "solve_via_data", spy)
    MilpSelector(time_limit_s=0.75, backend="cvxpy").select(random_problem(6))
    assert seen["time_limit"] == pytest.approx(0.75, rel=0.01)


def test_time_limit_and_gap_reach_highs_directly(monkeypatch):
    seen: dict[str, object] = {}
    original = highspy.Highs.setOptionValue

    def spy(self, name, value):
        seen[name] = value
        return original(self, name, value)

    monkeypatch.setattr(highspy.Highs, "setOptionValue", spy)
    MilpSelector(time_limit_s=0.75).select(random_problem(6))
    assert seen["time_limit"] == pytest.approx(0.75, rel=0.01)
    assert seen["mip_rel_gap"] == select_mod._MIP_REL_GAP and seen["output_flag"] is False


def test_make_selector_follows_the_config():
    assert isinstance(make_selector(PlanConfig(solver="greedy")), GreedySelector)
    milp = make_selector(PlanConfig(time_limit_s=0.5, strict_cover=True))
    assert isinstance(milp, MilpSelector)
    assert milp.time_limit_s == 0.5 and milp.strict_cover and milp.backend == "highs"
    assert make_selector(PlanConfig(solver="cvxpy")).backend == "cvxpy"  # type: ignore[union-attr]
    selector: Selector = milp  # both satisfy the protocol
    assert isinstance(selector.select(random_problem(1)), SelectionResult)


def _counted_runs(monkeypatch) -> list[bool]:
    """HiGHS' runs from here on, each True where it ran the integer solver."""
    runs: list[bool] = []
    original = highspy.Highs.run

    def counted(self):
        runs.append(any(t == highspy.HighsVarType.kInteger for t in self.getLp().integrality_))
        return original(self)

    monkeypatch.setattr(highspy.Highs, "run", counted)
    return runs


def test_a_fractional_relaxation_is_branched_before_the_integer_solver(monkeypatch):
    """The odd cycle: the relaxation takes every plan by half (1.5 plans' gain), the
    program only one. The selection branches on the relaxation (the root, then a plan
    fixed to 1, whose relaxation is integral, then fixed to 0, pruned): three HiGHS
    runs, never the integer solver, and the answer is one plan. When branching gives
    up (here after one relaxation) HiGHS' integer solver answers: two runs. When the
    relaxation's vertex is integral it is the answer, HiGHS run once."""
    problem = _odd_cycle()
    runs = _counted_runs(monkeypatch)
    result = MilpSelector().select(problem)
    assert runs == [False, False, False] and result.status == "optimal"
    assert sorted(result.chosen.tolist()) == [0, 0, 1] and result.gap == 0.0
    assert_allclose(result.objective, brute_force(problem), rtol=OBJ_RTOL)
    runs.clear()
    monkeypatch.setattr(branch_mod, "MAX_NODES", 1)
    given_up = MilpSelector().select(problem)
    assert runs == [False, True] and given_up.status == "optimal"
    assert_allclose(given_up.objective, result.objective, rtol=OBJ_RTOL)
    runs.clear()
    disjoint = [plan_set([i], [[0], [1]], [10_000.0, 12_000.0]) for i in range(3)]
    easy = SelectionProblem.from_plan_sets(
        disjoint, {0: 1.0, 1: 1.0, 2: 1.0}, alpha=0.5, energy_ref_j=E_REF
    )
    assert MilpSelector().select(easy).chosen.tolist() == [1, 1, 1] and runs == [False]


def test_a_busy_machine_branches_as_an_idle_one(monkeypatch):
    """The branching gives up at half the time limit in CPU seconds, not on the wall
    clock: on a machine busy with other work (here a wall clock that leaps a minute at
    every look) the odd cycle is still branched, never handed to the integer solver,
    whose answer among equal plans may differ (the same bytes under any load). HiGHS'
    own limit, wall seconds summed over the object's runs, is lifted while it branches,
    so no relaxation stops at it either."""
    import time

    problem = _odd_cycle()
    idle = MilpSelector().select(problem)
    clock = iter(range(0, 10**6, 60))
    monkeypatch.setattr(time, "perf_counter", lambda: float(next(clock)))
    runs = _counted_runs(monkeypatch)
    limits: list[float] = []
    counted = highspy.Highs.run

    def limited(self):
        value = self.getOptionValue("time_limit")  # (status, value) in some versions
        limits.append(value[-1] if isinstance(value, tuple) else value)
        return counted(self)

    monkeypatch.setattr(highspy.Highs, "run", limited)
    busy = MilpSelector(time_limit_s=2.0).select(problem)
    assert runs == [False, False, False] and busy.chosen.tolist() == idle.chosen.tolist()
    assert limits[0] < 2.0 and limits[1:] == [highspy.kHighsInf] * 2


def _overlapping(seed: int) -> SelectionProblem:
    """5 drones whose plans overlap in pairs and triples of 7 requests (odd cycles)."""
    rng = np.random.default_rng(seed)
    n_req = 7
    delay = {i: float(rng.uniform(0, 3)) for i in range(n_req)}
    sets = []
    for _ in range(5):
        ids = np.arange(n_req)
        picks = [rng.choice(n_req, int(rng.integers(2, 4)), replace=False) for _ in range(4)]
        members = np.vstack([np.zeros(n_req, bool)] + [np.isin(ids, p) for p in picks])
        energy = 10_000.0 + 8_000.0 * members.sum(axis=1) + rng.uniform(0, 3_000, 5)
        sets.append(plan_set(ids, members, energy))
    return SelectionProblem.from_plan_sets(sets, delay, alpha=0.5, energy_ref_j=E_REF)


def test_branching_finds_the_optimum_of_fractional_programs(monkeypatch):
    """60 random programs with overlapping plans, many with fractional relaxations: every
    selection is brute force's optimum, and where the relaxation was fractional (at
    least 15 of them) branching, not the integer solver, found it."""
    integer: list[bool] = []
    original = highspy.Highs.run

    def spy(self):
        integer.append(any(t == highspy.HighsVarType.kInteger for t in self.getLp().integrality_))
        return original(self)

    monkeypatch.setattr(highspy.Highs, "run", spy)
    branched = 0
    for seed in range(100, 160):
        problem = _overlapping(seed)
        integer.clear()
        result = MilpSelector().select(problem)
        assert result.status == "optimal" and not result.fallback and not any(integer)
        assert_allclose(result.objective, brute_force(problem), rtol=OBJ_RTOL)
        branched += len(integer) > 1
    assert branched >= 15, branched


def _odd_cycle() -> SelectionProblem:
    """Three drones, each with one plan serving two of three requests: the relaxation
    is fractional, so HiGHS' branch and bound runs."""
    ids = [0, 1, 2]
    pairs = [[1, 1, 0], [0, 1, 1], [1, 0, 1]]
    sets = [plan_set(ids, [[0, 0, 0], pair], [10_000.0, 12_000.0]) for pair in pairs]
    return SelectionProblem.from_plan_sets(
        sets, {0: 1.0, 1: 1.0, 2: 1.0}, alpha=0.5, energy_ref_j=E_REF
    )


def test_the_selection_runs_highs_on_one_thread_whoever_started_it(monkeypatch):
    """Another solver object in the process (cvxpy's, a notebook's) may start HiGHS'
    scheduler with two threads; HiGHS then refuses a one-thread run. The selection
    restarts the scheduler and still finds the optimum, on one thread."""
    other = highspy.Highs()
    other.setOptionValue("output_flag", False)
    other.setOptionValue("threads", 2)
    highspy.Highs.resetGlobalScheduler(True)
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = 2, 1
    lp.col_cost_ = np.array([-1.0, -1.0])
    lp.col_lower_, lp.col_upper_ = np.zeros(2), np.ones(2)
    lp.row_lower_, lp.row_upper_ = np.array([-highspy.kHighsInf]), np.array([1.5])
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.start_ = np.array([0, 1, 2])
    lp.a_matrix_.index_, lp.a_matrix_.value_ = np.array([0, 0]), np.array([1.0, 1.0])
    lp.integrality_ = [highspy.HighsVarType.kInteger] * 2
    other.passModel(lp)
    other.run()
    assert other.getModelStatus() == highspy.HighsModelStatus.kOptimal  # on two threads
    threads = []
    original = highspy.Highs.setOptionValue

    def spy(self, name, value):
        if name == "threads":
            threads.append(value)
        return original(self, name, value)

    monkeypatch.setattr(highspy.Highs, "setOptionValue", spy)
    problem = _odd_cycle()
    result = MilpSelector().select(problem)
    assert result.status == "optimal" and not result.fallback and set(threads) == {1}
    assert_allclose(result.objective, brute_force(problem), rtol=OBJ_RTOL)


def _result(status, fallback=False, **kw) -> SelectionResult:
    return SelectionResult(np.zeros(1, np.int64), 0.0, status, fallback, 0.0, 0.0, **kw)


def test_status_text_renders_each_story():
    """The words route files and the command line print, from the typed result."""
    S, V = SelectionStatus, SolveVerdict
    assert _result(S.GREEDY).status_text == "greedy" and str(_result(S.DIRECT)) == "direct"
    assert _result(S.OPTIMAL, solves=(V(S.OPTIMAL),)).status_text == "optimal"
    timed = _result(S.TIME_LIMIT, True, solves=(V(S.TIME_LIMIT),))
    assert timed.status_text == "time limit; fallback: greedy"
    odd = _result(S.OTHER, True, solves=(V(S.OTHER, "kInterrupt"),))
    assert odd.status_text == "kInterrupt; fallback: greedy"
    crash = V(S.SOLVER_ERROR, "RuntimeError: boom")
    assert str(crash) == "solver error (RuntimeError: boom)"
    bad = V(S.OPTIMAL, unused="rejected: a request is not covered")
    assert str(bad) == "optimal (rejected: a request is not covered)"
    strict = _result(S.OPTIMAL, strict_cover=True, solves=(V(S.OPTIMAL),))
    assert strict.status_text == "strict cover: optimal"
    failed = _result(S.OPTIMAL, strict_cover=True, solves=(V(S.INFEASIBLE), V(S.OPTIMAL)))
    assert failed.status_text == "strict cover infeasible; relaxed: optimal"
    holes = _result(
        S.TIME_LIMIT,
        True,
        strict_cover=True,
        uncovered=(9, 8, 7, 6, 5, 4),
        solves=(V(S.TIME_LIMIT),),
    )
    assert holes.status_text == (
        "strict cover infeasible (in no plan: [9, 8, 7, 6, 5]); relaxed: time limit; "
        "fallback: greedy"
    )


@pytest.mark.parametrize("backend", ["cvxpy", "highs"])
def test_optimal_result_is_typed_with_its_bound(backend):
    problem = random_problem(11)
    result = MilpSelector(backend=backend).select(problem)
    assert result.status is SelectionStatus.OPTIMAL and not result.fallback
    assert result.solves == (SolveVerdict(SelectionStatus.OPTIMAL),)
    assert result.bound is not None and result.gap is not None and result.gap <= 1e-6
    # the bound is in joules, below the optimum and within the solver's gap of it
    assert result.bound <= result.objective + 1e-6 * abs(result.objective)
    assert_allclose(result.bound, result.objective, rtol=1e-6)


def test_fallback_keeps_the_failed_verdict(monkeypatch):
    def timed_out(milp, strict, limit):
        return select_mod._Attempt(None, "kTimeLimit", 0.001, 0.002, bound=-0.5, gap=None)

    monkeypatch.setitem(select_mod._BACKENDS, "highs", timed_out)
    result = MilpSelector().select(random_problem(4))
    assert result.status is SelectionStatus.TIME_LIMIT and result.fallback
    assert result.bound is not None and result.gap is None
    assert GreedySelector().select(random_problem(4)).status is SelectionStatus.GREEDY


def test_importing_the_selection_touches_no_file_descriptor():
    """The HiGHS banner is silenced on the first solve, not on import."""
    import subprocess
    import sys

    code = (
        "import os\n"
        "calls = []\n"
        "real = os.dup2\n"
        "os.dup2 = lambda *a: (calls.append(a), real(*a))[1]\n"
        "import marops_cli.plans.select\n"
        "import marops_cli.plans.highs as s\n"
        "assert calls == [] and not s._banner_silenced, calls\n"
        "s.silence_highs_banner()\n"
        "assert len(calls) == 2 and s._banner_silenced\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
