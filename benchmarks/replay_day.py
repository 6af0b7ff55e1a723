"""Wall time per replayed day for each method, basic scenario (issue 4).

16 k-means depots (from the history days), 8 drones, 30-minute windows, α = 0.5,
on the bundled example's held-out days. Prints the median over days and repeats,
and the ratio ops-global / greedy.

    python benchmarks/replay_day.py [DATA] [--repeats 3] [--smoke]

``--smoke``: the last day only, once (CI runs it so the script keeps up with the library).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).parent.resolve()]

from marops_cli.config import PlannerConfig  # noqa: E402
from marops_cli.methods import method as method_spec  # noqa: E402
from marops_cli.sim.scenario import METHODS, load_fleet, load_scenario, method_policy, replay  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("data", nargs="?", default="examples/shanghai_synth.csv")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--methods", default=",".join(m for m in METHODS if m != "stay"))
    ap.add_argument("--smoke", action="store_true", help="the last day, 1 repeat (CI)")
    args = ap.parse_args()
    cfg = PlannerConfig()
    base = load_scenario(args.data, cfg)
    days = base.table.days()[-1 if args.smoke else -2 :]  # held out from segmentation below
    if args.smoke:
        args.repeats = 1
    results: dict[str, list[float]] = {}
    requests: list[int] = []
    for method in args.methods.split(","):
        mcfg = cfg.model_copy(deep=True)
        mcfg.segment.method = method_spec(method).segmentation
        try:
            pol = method_policy(method, None, 0)
        except Exception as exc:  # a method without a trained actor yet
            print(f"{method:>11}: skipped ({exc})")
            continue
        scn = load_scenario(args.data, mcfg, replay_days=days, table=base.table)
        fleet = load_fleet(None, scn.depots, 8, mcfg)
        times = []
        for _ in range(args.repeats):
            for day in days:
                t0 = time.perf_counter()
                res, reqs, _ = replay(scn, day, fleet, pol, method)
                times.append(time.perf_counter() - t0)
                requests.append(len(reqs))
        results[method] = times
    print(
        f"basic scenario: 16 depots, 8 drones, {statistics.mean(requests):.0f} requests/day, "
        f"{len(days)} days x {args.repeats} repeats"
    )
    print(f"{'method':>11}  {'median s/day':>12}  {'min':>7}  {'max':>7}")
    for method, times in results.items():
        print(
            f"{method:>11}  {statistics.median(times):12.3f}  {min(times):7.3f}  {max(times):7.3f}"
        )
    if "ops-global" in results and "greedy" in results:
        ratio = statistics.median(results["ops-global"]) / statistics.median(results["greedy"])
        print(f"ratio ops-global / greedy: {ratio:.2f} (paper: 6.23 s / 0.46 s = 13.5)")


if __name__ == "__main__":
    main()
