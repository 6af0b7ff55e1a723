"""Timing of visiting orders and plan selection; prints figures, is not a test.

    .venv/bin/python -m benchmarks.selection [--repeat 50] [--drones 8] [--candidates 5] [--smoke]

(it also runs as a script: ``python benchmarks/selection.py``)

* the exact (DP over subsets) and greedy orders of every subset, 5 .. 12 candidates;
* plan selection on random windows (``--drones`` drones with ``--candidates``
  candidates each, drawn with overlap from a shared pool): build + solve through
  cvxpy and through highspy directly, interleaved, median over ``--repeat`` runs.

``--smoke``: 5 candidates and one window, once each (CI runs it so the script keeps up
with the library).
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from functools import partial

import numpy as np

from marops_cli.config import PlanConfig
from marops_cli.energy import EnergyModel
from marops_cli.plans import (
    Candidates,
    GreedySelector,
    MilpSelector,
    SelectionProblem,
    build_plans,
    subset_orders,
)


def _median_ms(fn: Callable[[], object], repeat: int) -> float:
    fn()  # warm-up
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


def window(seed: int, drones: int, candidates: int, model: EnergyModel) -> SelectionProblem:
    """A random window: a 4 km square, a pool of 4 × drones requests, overlapping sets."""
    rng = np.random.default_rng(seed)
    pool = 4 * drones
    xy = rng.uniform(0, 4000, (pool, 2))
    weight = np.clip(rng.lognormal(np.log(0.5), 0.6, pool), 0.1, 2.5)
    delay = {i: float(rng.uniform(0, 3)) for i in range(pool)}
    sets = []
    for _ in range(drones):
        ids = rng.choice(pool, candidates, replace=False)
        start, end = rng.uniform(1000, 3000, (2, 2))
        own = Candidates(xy[ids], weight[ids], ids)
        sets.append(build_plans(start, end, own, model, PlanConfig()))
    return SelectionProblem.from_plan_sets(sets, delay, alpha=0.5, energy_ref_j=model.usable_j)


def bench_orders(model: EnergyModel, repeat: int, sizes: tuple[int, ...]) -> None:
    rng = np.random.default_rng(0)
    print("visiting order of every subset (ms, median)")
    for n in sizes:
        xy = rng.uniform(0, 2000, (n, 2))
        w = rng.uniform(0.05, 2.5 / n, n)
        reps = repeat if n <= 8 else max(5, repeat // 10)
        timed = {
            method: _median_ms(
                partial(subset_orders, (0, 0), (500, 500), xy, w, model, method), reps
            )
            for method in ("exact", "greedy")
        }
        exact, greedy = timed["exact"], timed["greedy"]
        print(f"  n={n:2d} ({1 << n:5d} subsets): exact {exact:7.3f}  greedy {greedy:7.3f}")


def bench_select(
    model: EnergyModel, repeat: int, drones: int, candidates: int, windows: int
) -> None:
    print(f"selection, {drones} drones x {candidates} candidates (ms, median of {repeat})")
    ratios = []
    for seed in range(windows):
        problem = window(seed, drones, candidates, model)
        sel = {b: MilpSelector(backend=b) for b in ("cvxpy", "highs")}
        res = {b: s.select(problem) for b, s in sel.items()}
        assert abs(res["cvxpy"].objective - res["highs"].objective) <= 1e-6 * abs(
            res["highs"].objective
        )
        samples: dict[str, list[tuple[float, float]]] = {"cvxpy": [], "highs": []}
        for _ in range(repeat):  # interleaved, so drift hits both alike
            for b, s in sel.items():
                r = s.select(problem)
                samples[b].append((r.build_s, r.solve_s))
        med = {
            b: (
                1e3 * statistics.median(x[0] for x in v),
                1e3 * statistics.median(x[1] for x in v),
                1e3 * statistics.median(x[0] + x[1] for x in v),
            )
            for b, v in samples.items()
        }
        ratio = med["cvxpy"][2] / med["highs"][2]
        ratios.append(ratio)
        greedy = GreedySelector().select(problem)
        gap = (greedy.objective - res["highs"].objective) / abs(res["highs"].objective)
        print(
            f"  seed {seed}: {problem.n_plans} plans, {problem.cover.shape[0]} requests | "
            f"cvxpy build {med['cvxpy'][0]:.2f} solve {med['cvxpy'][1]:.2f} "
            f"total {med['cvxpy'][2]:.2f} | highspy build {med['highs'][0]:.2f} "
            f"solve {med['highs'][1]:.2f} total {med['highs'][2]:.2f} | ratio {ratio:.2f} | "
            f"greedy +{100 * gap:.1f} %"
        )
    print(f"  cvxpy / highspy (build + solve): median ratio {statistics.median(ratios):.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=50)
    parser.add_argument("--drones", type=int, default=8)
    parser.add_argument("--candidates", type=int, default=5)
    parser.add_argument("--smoke", action="store_true", help="smallest sizes, 1 repeat (CI)")
    args = parser.parse_args()
    model = EnergyModel()
    if args.smoke:
        args.repeat = 1
    bench_orders(model, args.repeat, (5,) if args.smoke else (5, 8, 10, 12))
    bench_select(model, args.repeat, args.drones, args.candidates, 1 if args.smoke else 5)


if __name__ == "__main__":
    main()
