"""Wall time of one planning window (``plan_routes``), split by stage; prints figures.

Two scenarios, each planned ``--repeats`` times on the same window:

* basic: the example's day 2022-08-11 (16 k-means depots from the other days, 8
  drones at the busiest depots, M̂ = 5) with every request of the day made pending at
  mid-day window 8 (about 500 pending requests);
* large: 64 k-means depots over a 20 km square, 100 drones, 10,000 pending requests
  drawn around 40 clustered hubs (a synthetic city a few times the example's size).

For each, the median of ``WindowPlan.timings`` (candidates, plans, model build, solve,
total) and of the process CPU time of the whole window (and the fastest window's total
and CPU), for the range scope (greedy flight-range policy) and the global scope
(OPS-global), with the selector a replay uses (``make_selector``); then the same
selection program solved through cvxpy and through highspy directly
(``solve_highs_direct``), interleaved, with the cvxpy/direct ratio.
Goals for the basic scenario: a window under 50 ms; cvxpy build + solve within 1.5×
of direct HiGHS. A one-plan program (one drone, one parcel) shows cvxpy's fixed
cost per program, which alone exceeds 1.5× the direct solve of the basic window.

    python benchmarks/plan_window.py [DATA] [--repeats 20] [--profile] [--smoke]

``--smoke`` plans the basic window once per scope (CI runs it so the script keeps up
with the library).
"""

from __future__ import annotations

import argparse
import cProfile
import datetime as dt
import io
import os
import pstats
import statistics
import sys
import time
from pathlib import Path

sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).parent.resolve()]

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402

from marops_cli.config import PlannerConfig, SegmentConfig  # noqa: E402
from marops_cli.data.frame import Frame  # noqa: E402
from marops_cli.data.prepare import prepare_day  # noqa: E402
from marops_cli.energy import EnergyModel  # noqa: E402
from marops_cli.plans.plans import SelectionProblem  # noqa: E402
from marops_cli.plans.ranges import delays_h, range_table  # noqa: E402
from marops_cli.plans.select import (  # noqa: E402
    MilpSelector,
    SelectionResult,
    Selector,
    make_selector,
    solve_highs_direct,
)
from marops_cli.plans.window import plan_routes  # noqa: E402
from marops_cli.policies.base import WindowView  # noqa: E402
from marops_cli.policies.baselines import GreedyPolicy  # noqa: E402
from marops_cli.segment import segment_points  # noqa: E402
from marops_cli.sim.scenario import load_scenario  # noqa: E402
from marops_cli.sim.state import DayState, default_fleet  # noqa: E402

STAGES = ("candidates", "plans", "build", "solve", "total", "cpu")
MID_WINDOW = 8


def basic_view(data: str, cfg: PlannerConfig) -> WindowView:
    """Day 0811 of the example, every request pending at window 8, 8 drones."""
    day = dt.date(2022, 8, 11)
    scn = load_scenario(data, cfg, replay_days=[day])
    reqs = prepare_day(scn.table, scn.frame, day, cfg.data)
    reqs.visible_w[:] = 0  # all of the day's requests are known and undelivered
    fleet = default_fleet(scn.depots, cfg.sim.drones)
    model = EnergyModel.of(cfg.energy)
    state = DayState(reqs, scn.depots, fleet, cfg.plan.coverage, cfg.plan.ties, model=model)
    return state.view(MID_WINDOW)


def large_view(cfg: PlannerConfig, seed: int = 0) -> WindowView:
    """64 depots, 100 drones, 10,000 pending requests in a 20 km square."""
    rng = np.random.default_rng(seed)
    half = 10_000.0
    n_req, n_hubs = 10_000, 40
    hubs = rng.uniform(-0.8 * half, 0.8 * half, (n_hubs, 2))
    share = rng.dirichlet(np.ones(n_hubs))
    which = rng.choice(n_hubs, n_req, p=share)
    xy = hubs[which] + rng.normal(0.0, rng.uniform(300, 1500, n_hubs)[which, None], (n_req, 2))
    xy = np.clip(xy, -half, half)
    hist = hubs[rng.choice(n_hubs, 5 * n_req, p=share)] + rng.normal(0, 900, (5 * n_req, 2))
    frame = Frame(121.47, 31.23, 20.0)
    seg = SegmentConfig(n_depots=64, n_actions=cfg.segment.n_actions)
    depots = segment_points(hist[:, 0], hist[:, 1], frame, seg)
    due_w = rng.integers(0, 16, n_req)
    weight = np.clip(rng.lognormal(np.log(0.5), 0.6, n_req), 0.1, 2.5)
    return WindowView.paper(
        EnergyModel.of(cfg.energy),
        t=MID_WINDOW,
        n_windows=16,
        window_h=0.5,
        depots=depots,
        ranges=range_table(depots, cfg.plan.coverage),
        drone_depot=default_fleet(depots, 100),
        pending_idx=np.arange(n_req),
        pending_xy=xy,
        pending_area=depots.assign(xy[:, 0], xy[:, 1]),
        pending_delay_h=delays_h(due_w, MID_WINDOW, 0.5),
        pending_due_w=due_w,
        pending_due_s=due_w * 1800.0 + rng.uniform(0, 1800, n_req),
        pending_weight=weight,
    )


class Recording:
    """A selector that keeps the last program it was given, then lets ``inner`` solve it."""

    def __init__(self, inner: Selector) -> None:
        self.inner = inner
        self.problem: SelectionProblem | None = None

    def select(self, problem: SelectionProblem) -> SelectionResult:
        self.problem = problem
        return self.inner.select(problem)


def problem_of(
    view: WindowView, actions: np.ndarray, model: EnergyModel, cfg: PlannerConfig, scope: str
) -> SelectionProblem:
    """The selection program ``plan_routes`` builds for this window (caught on its way to
    the selector, so it is the planner's own whatever its plan sets)."""
    rec = Recording(make_selector(cfg.plan))
    plan_routes(view, actions, model, cfg.plan, rec, scope)
    assert rec.problem is not None
    return rec.problem


def ms(xs: list[float]) -> str:
    return f"{1e3 * statistics.median(xs):8.2f}"


def bench(name: str, view: WindowView, cfg: PlannerConfig, repeats: int, profile: bool) -> None:
    model = EnergyModel(cfg.energy)
    actions = GreedyPolicy().act(view)
    selector = make_selector(cfg.plan)  # the one a replay uses
    print(
        f"\n{name}: {len(view.depots)} depots, {view.n_drones} drones, "
        f"{view.pending_idx.size} pending requests, M̂ = {cfg.plan.max_parcels}, "
        f"window {view.t}, {repeats} repeats (median ms)"
    )
    print(f"{'scope':>7} {'cands':>6} {'plans':>6} " + " ".join(f"{s:>8}" for s in STAGES))
    for scope in ("range", "global"):
        plan_routes(view, actions, model, cfg.plan, selector, scope)  # warm-up
        times: dict[str, list[float]] = {s: [] for s in STAGES}
        for _ in range(repeats):
            c0 = time.process_time()
            plan = plan_routes(view, actions, model, cfg.plan, selector, scope)
            times["cpu"].append(time.process_time() - c0)  # less sensitive to a busy machine
            for s in STAGES[:-1]:
                times[s].append(plan.timings[s])
        n_plans = problem_of(view, actions, model, cfg, scope).n_plans
        print(
            f"{scope:>7} {plan.n_candidates:6d} {n_plans:6d} "
            + " ".join(ms(times[s]) for s in STAGES)
            + f"   ({plan.selection.status_text}, served "
            f"{sum(len(r.stops) for r in plan.routes)}; min total "
            f"{1e3 * min(times['total']):.2f}, cpu {1e3 * min(times['cpu']):.2f})"
        )
        if profile:
            prof = cProfile.Profile()
            prof.enable()
            for _ in range(3):
                plan_routes(view, actions, model, cfg.plan, selector, scope)
            prof.disable()
            buf = io.StringIO()
            pstats.Stats(prof, stream=buf).sort_stats("cumulative").print_stats(18)
            print(buf.getvalue())

    print(f"selection only (same program), {repeats} repeats, median ms:")
    print(f"{'scope':>7} {'backend':>8} {'build':>8} {'solve':>8} {'b+s':>8} {'wall':>8}  ratio")
    for scope in ("range", "global"):
        compare(scope, problem_of(view, actions, model, cfg, scope), cfg, repeats)
    if name == "basic":  # cvxpy's fixed cost: even a one-variable program takes milliseconds
        compare("1 plan", one_plan_problem(model.usable_j), cfg, repeats)
        print(f"{'1 plan':>7} cvxpy re-solving one cached (DPP) program: {dpp_resolve_ms(repeats)}")


def dpp_resolve_ms(repeats: int) -> str:
    """Median ms to re-solve a one-variable boolean program whose cost is a cvxpy Parameter:
    cvxpy's cached fast path, the least it can spend on any program it did not build."""
    import cvxpy as cp

    cost = cp.Parameter(1)
    x = cp.Variable(1, boolean=True)
    prob = cp.Problem(cp.Minimize(cost @ x), [x <= 1])
    times = []
    for i in range(repeats + 1):
        cost.value = np.array([-1.0 - i % 3])
        t0 = time.perf_counter()
        data, chain, inverse = prob.get_problem_data(cp.HIGHS)
        prob.unpack_results(chain.solve_via_data(prob, data), chain, inverse)
        times.append(time.perf_counter() - t0)
    return f"{ms(times[1:]).strip()} ms (build + solve)"


def one_plan_problem(usable_j: float) -> SelectionProblem:
    """The smallest selection program: one drone, its empty plan and one plan of one parcel."""
    return SelectionProblem(
        energy_j=np.array([0.0, 50e3]),
        offsets=np.array([0, 2]),
        cover=sp.csr_matrix(np.array([[0.0, 1.0]])),
        request_ids=np.array([0]),
        value=np.array([1.0]),
        lam=usable_j,
    )


def compare(scope: str, problem: SelectionProblem, cfg: PlannerConfig, repeats: int) -> None:
    """Print the median build, solve and wall time through cvxpy and through highspy."""
    runs: dict[str, dict[str, list[float]]] = {
        b: {"build": [], "solve": [], "wall": []} for b in ("cvxpy", "direct")
    }
    cvxpy = MilpSelector(time_limit_s=cfg.plan.time_limit_s, backend="cvxpy")
    solvers = {
        "cvxpy": lambda p=problem: cvxpy.select(p),
        "direct": lambda p=problem: solve_highs_direct(p, cfg.plan.time_limit_s),
    }
    objective = {}
    for fn in solvers.values():
        fn()  # warm-up
    for _ in range(repeats):
        for b, fn in solvers.items():  # interleaved, so drift hits both alike
            t0 = time.perf_counter()
            res = fn()
            runs[b]["wall"].append(time.perf_counter() - t0)
            runs[b]["build"].append(res.build_s)
            runs[b]["solve"].append(res.solve_s)
            objective[b] = res.objective
    bs = {
        b: statistics.median([x + y for x, y in zip(r["build"], r["solve"], strict=True)])
        for b, r in runs.items()
    }
    for b, r in runs.items():
        ratio = f"{bs['cvxpy'] / bs['direct']:.2f}" if b == "cvxpy" else ""
        print(
            f"{scope:>7} {b:>8} {ms(r['build'])} {ms(r['solve'])} "
            f"{1e3 * bs[b]:8.2f} {ms(r['wall'])}  {ratio}"
        )
    gap = abs(objective["cvxpy"] - objective["direct"]) / max(abs(objective["direct"]), 1.0)
    print(f"{'':>7} same objective: {gap < 1e-6} (relative difference {gap:.1e})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("data", nargs="?", default="examples/shanghai_synth.csv")
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--scenarios", default="basic,large")
    ap.add_argument("--profile", action="store_true", help="cProfile 3 windows per scope")
    ap.add_argument("--smoke", action="store_true", help="the basic scenario, 1 repeat (CI)")
    args = ap.parse_args()
    cfg = PlannerConfig()
    names = args.scenarios.split(",")
    if args.smoke:
        names, args.repeats = ["basic"], 1
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"{os.cpu_count()} CPUs, load average {load} (other work skews the figures)")
    if "basic" in names:
        bench("basic", basic_view(args.data, cfg), cfg, args.repeats, args.profile)
    if "large" in names:
        bench("large", large_view(cfg), cfg, args.repeats, args.profile)


if __name__ == "__main__":
    main()
