"""Plan selection across drones (docs/method.md §4, paper Alg. 2 lines 13–16).

x_uk = 1 if drone u flies plan k; each drone flies exactly one plan; each request is
served at most once. Minimise Σ E_uk x_uk + λ Σ_c v_c (1 − y_c) with
y_c = Σ_{k ∋ c} x_uk ≤ 1, v_c = 1 + delay_c (h), λ = ((1 − α)/α) · E_ref. Expanding
y_c gives per-plan costs c_uk = E_uk − λ Σ_{c ∈ p_uk} v_c plus the constant λ Σ_c v_c.
``strict_cover`` adds the paper's literal constraint (every candidate served exactly
once) when it is feasible.

What the solvers see: a drone's empty plan serves nothing, so it is the slack of the
drone's row. Substituting x_u0 = 1 − Σ_{k>0} x_uk leaves one variable per non-empty
plan with cost c_uk − c_u0 and rows that are all "≤ 1" (Σ_{k>0} x_uk ≤ 1 per drone,
y_c ≤ 1 per request): one stacked sparse constraint, which keeps cvxpy's
canonicalisation short. Both backends (cvxpy and highspy directly) solve this same
matrix.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Literal, Protocol

import highspy
import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from ..config import PlanConfig
from .branch import branch_and_bound
from .highs import new_highs, run_highs, silence_highs_banner
from .plans import SelectionProblem

__all__ = [
    "GreedySelector",
    "MilpSelector",
    "SelectionProblem",  # defined in plans.py, re-exported for callers of the selection
    "SelectionResult",
    "SelectionStatus",
    "Selector",
    "SolveVerdict",
    "greedy_select",
    "make_selector",
    "solve_highs_direct",
]


_MIP_REL_GAP = 1e-7  # HiGHS' default 1e-4 of the objective is too loose to be "optimal"
_INTEGRAL_TOL = 1e-9  # a relaxation's vertex this close to 0/1 everywhere is integral
_CANON_BACKEND = "CPP"  # measured faster than "SCIPY" on these models (benchmarks/selection.py)


class SelectionStatus(StrEnum):
    """How a selection, or one solve of the program, ended."""

    OPTIMAL = "optimal"
    TIME_LIMIT = "time limit"
    """Stopped at the time limit (with an incumbent, that is the selection)."""
    INFEASIBLE = "infeasible"
    SOLVER_ERROR = "solver error"
    OTHER = "other"
    """Any other HiGHS model status (its name is in :attr:`SolveVerdict.detail`)."""
    GREEDY = "greedy"
    """Chosen by :func:`greedy_select` alone (the ``greedy`` solver)."""
    DIRECT = "direct"
    """Chosen by a policy directly (``policies/direct.py``)."""


_STATUS = {
    "kOptimal": SelectionStatus.OPTIMAL,
    "kTimeLimit": SelectionStatus.TIME_LIMIT,
    "kInfeasible": SelectionStatus.INFEASIBLE,
    "kUnboundedOrInfeasible": SelectionStatus.INFEASIBLE,
}


@dataclass(frozen=True)
class SolveVerdict:
    """One solve of the program: the solver's status and why its answer was not used."""

    status: SelectionStatus
    detail: str = ""
    """The HiGHS status name (``OTHER``) or the exception (``SOLVER_ERROR``)."""
    unused: str = ""
    """Why the answer was not used: "solution is not a selection" or "rejected: ..."."""

    def __str__(self) -> str:
        text = {
            SelectionStatus.OTHER: self.detail,
            SelectionStatus.SOLVER_ERROR: f"solver error ({self.detail})",
        }.get(self.status, self.status.value)
        return f"{text} ({self.unused})" if self.unused else text


@dataclass(frozen=True)
class SelectionResult:
    """Chosen plan (local index) per drone and how it was found.

    ``status`` is the verdict on the selection (the solve it came from; the failed solve's
    when ``fallback``); :attr:`status_text` (also ``str()``) tells the whole story in the
    words the command line prints (docs/method.md §4.3).
    """

    chosen: NDArray[np.int64]
    objective: float
    status: SelectionStatus
    fallback: bool
    """The solver gave no usable selection: :func:`greedy_select`'s was taken."""
    solve_s: float
    build_s: float
    bound: float | None = None
    """A lower bound on the objective (J) from the last solve, where HiGHS reports one."""
    gap: float | None = None
    """HiGHS' relative gap of the last solve (of the program it solved), where reported."""
    strict_cover: bool = False
    """The strict cover was asked for (``PlanConfig.strict_cover``)."""
    uncovered: tuple[int, ...] = ()
    """Requests in no plan, which made the strict cover infeasible before any solve."""
    solves: tuple[SolveVerdict, ...] = field(default=())
    """Each solve in order: the strict cover's when tried, then the relaxed program's."""

    @classmethod
    def without_solver(
        cls,
        problem: SelectionProblem,
        chosen: NDArray[np.int64],
        status: SelectionStatus,
        t0: float,
    ) -> SelectionResult:
        """A selection a rule made (no program built or solved) from ``t0`` on: its
        objective, and the time since ``t0`` as its solve time."""
        return cls(chosen, problem.objective(chosen), status, False, time.perf_counter() - t0, 0.0)

    @property
    def status_text(self) -> str:
        """The status in words, as printed, e.g. ``"optimal"``, ``"strict cover: optimal"``
        or ``"time limit; fallback: greedy"``."""
        if not self.solves:
            return str(self.status)
        if self.strict_cover and not self.uncovered and len(self.solves) == 1:
            return f"strict cover: {self.solves[0]}"  # the strict cover held
        head = ""
        if self.uncovered:
            head = f"strict cover infeasible (in no plan: {list(self.uncovered[:5])}); relaxed: "
        elif len(self.solves) == 2:
            head = f"strict cover {self.solves[0]}; relaxed: "
        tail = "; fallback: greedy" if self.fallback else ""
        return f"{head}{self.solves[-1]}{tail}"

    def __str__(self) -> str:
        return self.status_text


class Selector(Protocol):
    """Chooses one plan per drone."""

    def select(self, problem: SelectionProblem) -> SelectionResult: ...


@dataclass(frozen=True)
class _Milp:
    """The reduced program: one column per non-empty plan, every row "≤ 1" (or "= 1")."""

    cols: NDArray[np.int64]
    """Plan column (in the problem) of each variable."""
    cost: NDArray[np.float64]
    """c_uk − c_u0, scaled to O(1); the objective is recomputed in joules afterwards."""
    rows: sp.csr_matrix
    """``(U + R, n)``: the drone rows, then the request rows."""
    n_drones: int
    scale: float
    """``cost`` times ``scale`` plus ``offset`` is the objective in joules."""
    offset: float


def _reduce(problem: SelectionProblem) -> _Milp:
    empty = problem.offsets[:-1]
    keep = np.ones(problem.n_plans, dtype=bool)
    keep[empty] = False
    cols = np.flatnonzero(keep)
    n, u = cols.size, problem.n_drones
    owner = problem.drone[cols]
    cost = problem.cost[cols] - problem.cost[empty][owner]
    remap = np.cumsum(keep) - 1  # plan column -> variable (empty plans serve no request)
    cover = problem.cover.tocoo()
    rows = sp.csr_matrix(
        (
            np.ones(n + cover.nnz),
            (
                np.concatenate([owner, u + cover.row]),
                np.concatenate([np.arange(n), remap[cover.col]]),
            ),
        ),
        shape=(u + cover.shape[0], n),
    )
    scale = max(float(np.abs(cost).max(initial=0.0)), 1.0)
    offset = float(problem.cost[empty].sum()) + problem.constant
    return _Milp(cols, cost / scale, rows, u, scale, offset)


@dataclass
class _Attempt:
    x: NDArray[np.float64] | None
    status: str
    """The HiGHS model status name, or the solver error."""
    build_s: float
    solve_s: float
    bound: float | None = None
    """HiGHS' dual bound on the (scaled, reduced) program."""
    gap: float | None = None


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _decode(
    problem: SelectionProblem, milp: _Milp, x: NDArray[np.float64] | None
) -> NDArray[np.int64] | None:
    """Local plan index per drone from a 0/1 vector over non-empty plans; None if not one."""
    if x is None or x.shape != milp.cols.shape or not np.all(np.isfinite(x)):
        return None
    xr = np.round(x)
    if np.abs(x - xr).max(initial=0.0) > 1e-6 or xr.min(initial=0) < 0 or xr.max(initial=0) > 1:
        return None
    if np.any(milp.rows[: milp.n_drones] @ xr > 1):
        return None
    picked = milp.cols[xr > 0.5]
    chosen = np.zeros(problem.n_drones, dtype=np.int64)
    owner = problem.drone[picked]
    chosen[owner] = picked - problem.offsets[owner]
    return chosen


def _solve_cvxpy(milp: _Milp, strict: bool, time_limit_s: float) -> _Attempt:
    # Imported here: cvxpy (with the scipy.stats it loads) takes most of a second to
    # import, which the default direct HiGHS backend never needs.
    import cvxpy as cp

    silence_highs_banner()
    t0 = time.perf_counter()
    x = cp.Variable(milp.cols.size, boolean=True)
    u = milp.n_drones
    if strict and milp.rows.shape[0] > u:
        cons = [milp.rows[:u] @ x <= 1, milp.rows[u:] @ x == 1]
    else:
        cons = [milp.rows @ x <= 1]
    prob = cp.Problem(cp.Minimize(milp.cost @ x), cons)
    data, chain, inverse = prob.get_problem_data(
        cp.HIGHS, ignore_dpp=True, canon_backend=_CANON_BACKEND
    )
    t1 = time.perf_counter()
    # cvxpy passes solver keyword options to HiGHS' setOptionValue (cvxpy highs_conif.py)
    opts = {"time_limit": float(time_limit_s), "mip_rel_gap": _MIP_REL_GAP}
    raw = chain.solve_via_data(prob, data, solver_opts=opts)
    prob.unpack_results(raw, chain, inverse)
    info = raw["info"]
    found = info.primal_solution_status == highspy.kSolutionStatusFeasible
    xv = np.asarray(x.value, dtype=np.float64) if found and x.value is not None else None
    return _Attempt(
        xv,
        raw["model_status"],
        t1 - t0,
        time.perf_counter() - t1,
        _finite(info.mip_dual_bound),
        _finite(info.mip_gap),
    )


def _solve_highs(milp: _Milp, strict: bool, time_limit_s: float) -> _Attempt:
    t0, cpu0 = time.perf_counter(), time.thread_time()
    a = milp.rows.tocsc()
    n_row, n_col = a.shape
    lower = np.full(n_row, -highspy.kHighsInf)
    if strict:
        lower[milp.n_drones :] = 1.0
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = n_col, n_row
    lp.col_cost_ = milp.cost
    lp.col_lower_, lp.col_upper_ = np.zeros(n_col), np.ones(n_col)
    lp.row_lower_, lp.row_upper_ = lower, np.ones(n_row)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.start_, lp.a_matrix_.index_, lp.a_matrix_.value_ = a.indptr, a.indices, a.data
    h = new_highs()
    h.setOptionValue("time_limit", float(time_limit_s))
    h.setOptionValue("mip_rel_gap", _MIP_REL_GAP)
    # The linear relaxation first (a tenth of the program's time): when its optimal
    # vertex is integral it is the program's optimum too, and most windows' are.
    h.passModel(lp)
    t1 = time.perf_counter()
    run_highs(h)
    if h.getModelStatus() == highspy.HighsModelStatus.kOptimal:
        x = np.asarray(h.getSolution().col_value, dtype=np.float64)
        if np.abs(x - np.round(x)).max(initial=0.0) <= _INTEGRAL_TOL:
            # The relaxation's optimum bounds the program, and is attained: no gap.
            bound = _finite(h.getInfo().objective_function_value)
            return _Attempt(np.round(x), "kOptimal", t1 - t0, time.perf_counter() - t1, bound, 0.0)
        # A few branchings usually close it, far sooner than the integer solver starts.
        # Half the time limit in CPU seconds, this thread's: on a busy machine the wall
        # clock would hand the program to the integer solver sooner, and its answer may
        # differ. HiGHS' own limit (wall seconds, summed over the object's runs) is
        # lifted meanwhile, so that no relaxation stops at it.
        h.setOptionValue("time_limit", highspy.kHighsInf)
        half = cpu0 + 0.5 * float(time_limit_s)
        done = branch_and_bound(h, _MIP_REL_GAP, _INTEGRAL_TOL, half)
        if done is not None:
            gap = (done.objective - done.bound) / max(abs(done.objective), 1e-9)
            return _Attempt(
                done.x, "kOptimal", t1 - t0, time.perf_counter() - t1, _finite(done.bound), gap
            )
    lp.integrality_ = [highspy.HighsVarType.kInteger] * n_col
    h.passModel(lp)
    # What is left of the limit in CPU seconds, on HiGHS' clock of the object's runs.
    left = max(float(time_limit_s) - (time.thread_time() - cpu0), 0.01)
    h.setOptionValue("time_limit", h.getRunTime() + left)
    run_highs(h)
    info = h.getInfo()
    found = info.primal_solution_status == highspy.kSolutionStatusFeasible
    xv = np.asarray(h.getSolution().col_value, dtype=np.float64) if found else None
    return _Attempt(
        xv,
        h.getModelStatus().name,
        t1 - t0,
        time.perf_counter() - t1,
        _finite(info.mip_dual_bound),
        _finite(info.mip_gap),
    )


_Backend = Callable[[_Milp, bool, float], _Attempt]
_BACKENDS: dict[str, _Backend] = {"cvxpy": _solve_cvxpy, "highs": _solve_highs}


def greedy_select(problem: SelectionProblem) -> NDArray[np.int64]:
    """Plans by cost gain over the drone's empty plan, best first, if compatible.

    A plan is taken when its drone has none yet and none of its requests is taken;
    drones left over fly their empty plan. Always feasible.
    """
    cost = problem.cost
    gain = cost[problem.offsets[:-1]][problem.drone] - cost
    chosen = np.zeros(problem.n_drones, dtype=np.int64)
    assigned = np.zeros(problem.n_drones, dtype=bool)
    taken = np.zeros(problem.cover.shape[0], dtype=bool)
    by_plan = problem.cover.tocsc()
    for p in np.argsort(-gain, kind="stable"):
        if gain[p] <= 0:
            break
        u = problem.drone[p]
        reqs = by_plan.indices[by_plan.indptr[p] : by_plan.indptr[p + 1]]
        if assigned[u] or taken[reqs].any():
            continue
        chosen[u], assigned[u] = p - problem.offsets[u], True
        taken[reqs] = True
    return chosen


class GreedySelector:
    """:func:`greedy_select` as a :class:`Selector` (no strict cover, no solver)."""

    def select(self, problem: SelectionProblem) -> SelectionResult:
        t0 = time.perf_counter()
        chosen = greedy_select(problem)
        return SelectionResult.without_solver(problem, chosen, SelectionStatus.GREEDY, t0)


@dataclass
class MilpSelector:
    """The boolean program solved by HiGHS, through cvxpy or highspy directly.

    ``time_limit_s`` is the budget of one selection; a strict-cover attempt that fails
    leaves the relaxed solve the rest (at least a tenth of it). Any failure — solver
    error, infeasible, time limit without an incumbent, or a solution that does not
    verify — falls back to :func:`greedy_select` with ``fallback=True``.
    """

    time_limit_s: float = 2.0
    strict_cover: bool = False
    backend: Literal["cvxpy", "highs"] = "highs"

    def _attempt(
        self, problem: SelectionProblem, milp: _Milp, strict: bool, limit: float
    ) -> tuple[NDArray[np.int64] | None, _Attempt, SolveVerdict]:
        """One solve, decoded and verified; ``None`` when there is no usable selection."""
        if milp.cols.size == 0:  # only empty plans: nothing to decide
            att = _Attempt(np.zeros(0), "kOptimal", 0.0, 0.0)
        else:
            try:
                att = _BACKENDS[self.backend](milp, strict, limit)
            except Exception as exc:  # any solver failure means: fall back
                error = SolveVerdict(SelectionStatus.SOLVER_ERROR, f"{type(exc).__name__}: {exc}")
                return None, _Attempt(None, str(error), 0.0, 0.0), error
        status = _STATUS.get(att.status, SelectionStatus.OTHER)
        detail = att.status if status is SelectionStatus.OTHER else ""
        chosen = _decode(problem, milp, att.x)
        if chosen is None:
            unused = "solution is not a selection" if att.x is not None else ""
            return None, att, SolveVerdict(status, detail, unused)
        reason = problem.violation(chosen)
        if reason is None and strict and problem.served(chosen).min(initial=1) < 1:
            reason = "a request is not covered"
        if reason is not None:
            return None, att, SolveVerdict(status, detail, f"rejected: {reason}")
        return chosen, att, SolveVerdict(status, detail)

    def select(self, problem: SelectionProblem) -> SelectionResult:
        t0, cpu0 = time.perf_counter(), time.thread_time()  # budget: CPU, not wall
        milp = _reduce(problem)
        build_s, solve_s = time.perf_counter() - t0, 0.0
        solves: list[SolveVerdict] = []
        uncovered: tuple[int, ...] = ()
        if self.strict_cover:
            missing = problem.uncoverable()
            if missing.size:
                uncovered = tuple(int(i) for i in missing)
            else:
                chosen, att, verdict = self._attempt(problem, milp, True, self.time_limit_s)
                build_s, solve_s = build_s + att.build_s, solve_s + att.solve_s
                solves.append(verdict)
                if chosen is not None:
                    return self._result(problem, chosen, (att, milp), solves, (solve_s, build_s))
        spent = time.thread_time() - cpu0  # the same budget on a busy machine
        limit = max(self.time_limit_s - spent, 0.1 * self.time_limit_s)
        chosen, att, verdict = self._attempt(problem, milp, False, limit)
        build_s, solve_s = build_s + att.build_s, solve_s + att.solve_s
        solves.append(verdict)
        fallback = chosen is None
        if chosen is None:
            t1 = time.perf_counter()
            chosen = greedy_select(problem)
            solve_s += time.perf_counter() - t1
        return self._result(
            problem, chosen, (att, milp), solves, (solve_s, build_s), (uncovered, fallback)
        )

    def _result(
        self,
        problem: SelectionProblem,
        chosen: NDArray[np.int64],
        last: tuple[_Attempt, _Milp],
        solves: list[SolveVerdict],
        seconds: tuple[float, float],
        left: tuple[tuple[int, ...], bool] = ((), False),
    ) -> SelectionResult:
        """The result of the last solve ``att`` of the program ``milp`` (``last``), its
        bound back in joules; ``seconds`` the solve and build times, ``left`` the
        requests no plan covers (a strict cover given up) and whether the greedy
        fallback chose."""
        att, milp = last
        solve_s, build_s = seconds
        uncovered, fallback = left
        bound = None if att.bound is None else milp.offset + milp.scale * att.bound
        return SelectionResult(
            chosen,
            problem.objective(chosen),
            solves[-1].status,
            fallback,
            solve_s,
            build_s,
            bound=bound,
            gap=att.gap,
            strict_cover=self.strict_cover,
            uncovered=uncovered,
            solves=tuple(solves),
        )


def solve_highs_direct(
    problem: SelectionProblem, time_limit_s: float = 2.0, strict_cover: bool = False
) -> SelectionResult:
    """The same program through highspy without cvxpy (benchmarks, cross-checks)."""
    return MilpSelector(time_limit_s, strict_cover, backend="highs").select(problem)


def make_selector(cfg: PlanConfig) -> Selector:
    """The selector that ``cfg.solver`` names."""
    if cfg.solver == "greedy":
        return GreedySelector()
    return MilpSelector(
        time_limit_s=cfg.time_limit_s, strict_cover=cfg.strict_cover, backend=cfg.solver
    )
