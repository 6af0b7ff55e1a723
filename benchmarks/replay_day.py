"""What a replayed day costs, as cron runs it: whole ``marops replay-day`` processes.

For each method (default marops, ops-global and backlog) the same command is run as a
process of its own, ``--repeats`` times after one warm-up run each (methods taken in
turn, so a change in the machine's load falls on all of them): its wall time, its CPU
time (user + system of that process alone, from ``wait4``) and its peak resident
memory; min and median of each, side by side, and the ratios marops / ops-global
(min to min, median to median). The replay reads a depots file made once beforehand
(``marops segment`` of the history days), so every run does the same work;
``--no-depots`` times the bare command instead (segmenting, or its depots cache).

    python benchmarks/replay_day.py [DATA] [--date 0811] [--methods marops,ops-global,backlog]
                                    [--repeats 5] [--no-depots] [--in-process] [--smoke]

``--in-process`` measures the day's replay alone instead (``sim.scenario.replay`` in
this process, no start-up): the basic scenario, 16 k-means depots, 8 drones, every
method but stay on the example's last held-out days, with the ratio ops-global / greedy
(the paper's 6.23 s / 0.46 s).

``--smoke``: one run of each method, no warm-up (CI runs it so the script keeps up with
the command line; its figures mean nothing). Nothing is asserted: the machine may be
shared; run it on a quiet one and read min/median.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).parent.resolve()]

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "shanghai_synth.csv"
MAIN = "from marops_cli.cli.app import main; main()"
"""``marops`` as its console script runs it, from this interpreter."""


def marops(*args: str) -> list[str]:
    return [sys.executable, "-c", MAIN, *args]


def run(cmd: list[str]) -> tuple[float, float, float]:
    """(wall s, CPU s, peak MiB) of one command in a process of its own."""
    with tempfile.TemporaryFile() as err:
        t = time.perf_counter()
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t
        proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
        if proc.returncode:
            err.seek(0)
            tail = err.read().decode(errors="replace")[-2000:]
            raise SystemExit(f"failed ({proc.returncode}): {' '.join(cmd)}\n{tail}")
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0


def whole_process(args: argparse.Namespace) -> None:
    methods = args.methods.split(",")
    repeats = 1 if args.smoke else args.repeats
    with tempfile.TemporaryDirectory(prefix="marops-bench-") as tmp:
        base = ["replay-day", str(args.data), "--area", "square", "--date", args.date, "-q"]
        if not args.no_depots:
            depots = Path(tmp) / "depots.json"
            segment = ["segment", str(args.data), "--dates", args.history]
            run(marops(*segment, "--out", str(depots), "-q"))
            base += ["--depots", str(depots)]
        load = os.getloadavg()[0]

        def once(method: str, i: int) -> tuple[float, float, float]:
            return run(marops(*base, "--method", method, "--out", f"{tmp}/{method}-{i}"))

        if not args.smoke:
            for m in methods:  # page cache, compiled kernels' cache, depots cache
                once(m, -1)
        runs: dict[str, list[tuple[float, float, float]]] = {m: [] for m in methods}
        for i in range(repeats):
            for m in methods:
                runs[m].append(once(m, i))
    where = "a depots file" if not args.no_depots else "no depots file"
    print(
        f"marops replay-day {Path(args.data).name} --date {args.date} ({where}), whole "
        f"process, {repeats} run(s) each{'' if args.smoke else ' after a warm-up'}; "
        f"load {load:.2f} before, {os.getloadavg()[0]:.2f} after, {os.cpu_count()} CPUs"
    )
    print(
        f"{'method':>11}  {'wall min':>8}  {'median':>6}  {'CPU min':>7}  {'median':>6}  "
        f"{'peak MiB':>8}"
    )
    for m, rs in runs.items():
        wall, cpu, mem = ([r[k] for r in rs] for k in range(3))
        print(
            f"{m:>11}  {min(wall):8.2f}  {statistics.median(wall):6.2f}  {min(cpu):7.2f}  "
            f"{statistics.median(cpu):6.2f}  {max(mem):8.0f}"
        )
    if "marops" in runs and "ops-global" in runs:
        a, b = runs["marops"], runs["ops-global"]
        for k, what in ((0, "wall"), (1, "CPU")):
            x, y = [r[k] for r in a], [r[k] for r in b]
            print(
                f"marops / ops-global {what}: {min(x) / min(y):.2f} (min), "
                f"{statistics.median(x) / statistics.median(y):.2f} (median)"
            )


def in_process(args: argparse.Namespace) -> None:
    """The day's replay alone, in this process (the script's measurement before it
    timed whole processes)."""
    from marops_cli.config import PlannerConfig
    from marops_cli.methods import method as method_spec
    from marops_cli.sim.scenario import METHODS, load_fleet, load_scenario, method_policy, replay

    cfg = PlannerConfig()
    base = load_scenario(args.data, cfg)
    days = base.table.days()[-1 if args.smoke else -2 :]  # held out from segmentation below
    repeats = 1 if args.smoke else args.repeats
    methods = args.methods.split(",") if args.methods_given else [m for m in METHODS if m != "stay"]
    results: dict[str, list[float]] = {}
    requests: list[int] = []
    for method in methods:
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
        for _ in range(repeats):
            for day in days:
                t0 = time.perf_counter()
                res, reqs, _ = replay(scn, day, fleet, pol, method)
                times.append(time.perf_counter() - t0)
                requests.append(len(reqs))
        results[method] = times
    print(
        f"basic scenario: 16 depots, 8 drones, {statistics.mean(requests):.0f} requests/day, "
        f"{len(days)} days x {repeats} repeats (in this process)"
    )
    print(f"{'method':>11}  {'median s/day':>12}  {'min':>7}  {'max':>7}")
    for method, times in results.items():
        print(
            f"{method:>11}  {statistics.median(times):12.3f}  {min(times):7.3f}  {max(times):7.3f}"
        )
    if "ops-global" in results and "greedy" in results:
        ratio = statistics.median(results["ops-global"]) / statistics.median(results["greedy"])
        print(f"ratio ops-global / greedy: {ratio:.2f} (paper: 6.23 s / 0.46 s = 13.5)")


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("data", nargs="?", default=str(EXAMPLE))
    ap.add_argument("--date", default="0811", help="the day replayed [0811]")
    ap.add_argument(
        "--history", default="0801..0810", help="the days the depots file is segmented from"
    )
    ap.add_argument("--methods", default=None, help="[marops,ops-global,backlog]")
    ap.add_argument("--repeats", type=int, default=5, help="timed runs per method [5]")
    ap.add_argument("--no-depots", action="store_true", help="time the bare command")
    ap.add_argument("--in-process", action="store_true", help="the replay alone, no start-up")
    ap.add_argument("--smoke", action="store_true", help="one run of each method (CI)")
    args = ap.parse_args()
    args.methods_given = args.methods is not None
    if args.methods is None:
        args.methods = "marops,ops-global,backlog"
    (in_process if args.in_process else whole_process)(args)


if __name__ == "__main__":
    main()
