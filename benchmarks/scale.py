"""Whole cities and repeated runs: wall time and peak memory of the analyst's jobs.

Every figure is a whole ``marops`` process (as cron runs it), its wall time and its
peak resident memory (``ru_maxrss`` of that process alone):

* **City** (``--city``): a LaDe-shaped city file of ``--rows`` rows (default 1.5 M:
  181 days from 1 March of a 40 km polycentric city, ``SynthConfig``, seed 5): ``segment`` over the
  whole file, ``segment --hubs auto`` over its history days, and one day replayed over
  every hub (``replay-day --hubs``), with the share of the city's orders the hubs cover.
* **Repeated runs** (the bundled example): ``replay-day`` of one day with ``--depots``,
  median and min of ``--repeats`` runs, with the stages of one run (imports, reading,
  depots, the actor, planning, writing) measured in one process; each extra day of
  ``--dates`` from the slope between 2 and 12 days (with 2 workers and with 1), and
  between 1 and 5 days.
* **A city day** (always): the default ``replay-day`` of one day of a 6,000-orders-a-day
  polycentric city over the hubs it places, 2 workers, with the depots cache empty and
  filled, min and median of ``--repeats``.
* **Sweeps** (``--sweep``): ``evaluate`` over 30 days × 4 methods of a synthetic file
  with ``--workers 1`` and ``--workers 2`` side by side (ratio).

Nothing is asserted: the machine is shared; run it on a quiet one and read min/median.

    python benchmarks/scale.py [--city] [--rows 1500000] [--sweep] [--repeats 5] [--smoke]

``--smoke`` runs every part once on the least input (a two-day 8 km city, runs of two
and three days, a one-day sweep of two methods), so CI sees the script keep up with the
command line; its figures mean nothing.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).parent.resolve()]

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "shanghai_synth.csv"

# Runs a command as a child and prints its own peak memory (KiB) after it ends.
_WRAP = (
    "import resource, subprocess, sys\n"
    "r = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,"
    " text=True)\n"
    "sys.stderr.write(r.stderr[-2000:] if r.returncode else '')\n"
    "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
    "sys.exit(r.returncode)\n"
)
_STAGES = r"""
import time, sys, json
t0 = time.perf_counter()
from marops_cli.cli import app  # noqa: F401  (what the command line loads first)
t_cli = time.perf_counter()
from marops_cli.config import PlannerConfig
from marops_cli.data.reader import read_lade
from marops_cli.sim.scenario import load_scenario, load_fleet, method_policy, replay
from marops_cli.data.dates import parse_day
import datetime as dt
cfg = PlannerConfig()
day = dt.date(2022, 8, 11)
t1 = time.perf_counter()
table = read_lade(sys.argv[1], cfg.data)
t2 = time.perf_counter()
scn = load_scenario(sys.argv[1], cfg, depots_path=sys.argv[2], replay_days=[day], table=table)
t3 = time.perf_counter()
pol = method_policy("marops", None, 0)
t4 = time.perf_counter()
fleet = load_fleet(None, scn.depots, cfg.sim.drones, cfg)
res, reqs, metrics = replay(scn, day, fleet, pol, "marops")
t5 = time.perf_counter()
from marops_cli.energy import EnergyModel
from marops_cli.io.tables import build_tables
stops, routes = build_tables(reqs, scn.depots, res.plans, EnergyModel(cfg.energy), "marops")
import pyarrow.parquet as pq
pq.write_table(routes, sys.argv[3] + "/r.parquet")
pq.write_table(stops, sys.argv[3] + "/s.parquet")
t6 = time.perf_counter()
print(json.dumps({"start and CLI imports": t_cli - t0, "library imports": t1 - t_cli,
                  "read the file": t2 - t1, "depots and arrival profile": t3 - t2,
                  "load the actor (torch)": t4 - t3, "plan 16 windows": t5 - t4,
                  "build and write tables": t6 - t5}))
"""


def run(cmd: list[str], env: dict[str, str] | None = None) -> tuple[float, float]:
    """(wall s, peak MiB) of one command in its own process."""
    t = time.perf_counter()
    r = subprocess.run(
        [sys.executable, "-c", _WRAP, *cmd], capture_output=True, text=True, env=env, check=False
    )
    wall = time.perf_counter() - t
    if r.returncode:
        raise SystemExit(f"failed: {' '.join(cmd)}\n{r.stderr}")
    return wall, int(r.stdout.strip().splitlines()[-1]) / 1024.0


def marops(*args: str) -> list[str]:
    return [sys.executable, "-c", "from marops_cli.cli.app import main; main()", *args]


def city(rows: int, tmp: Path, per_day: float = 8300.0, extent_km: float = 40.0) -> None:
    from marops_cli.data.synth import SynthConfig, generate, write

    days = max(2, round(rows / per_day))
    path = tmp / "city.csv"
    t = time.perf_counter()
    # LaDe's times carry no year: the days must stay inside one (March to December).
    days = min(days, 300)
    cfg = SynthConfig(
        days=days,
        seed=5,
        start=dt.date(2022, 3, 1),
        orders_per_day=per_day,
        extent_km=extent_km,
        shape="polycentric",
    )
    write(generate(cfg), path)
    n = sum(1 for _ in path.open()) - 1
    print(
        f"city file: {n:,} rows, {days} days, {path.stat().st_size / 1e6:.0f} MB "
        f"(made in {time.perf_counter() - t:.1f} s)"
    )
    last = dt.date.fromordinal(cfg.start.toordinal() + days - 1)
    day = last.isoformat()  # the last day is replayed; the others are its history
    history = f"{cfg.start.isoformat()}..{(last - dt.timedelta(days=1)).isoformat()}"
    wall, mem = run(marops("segment", str(path), "--out", str(tmp / "depots.json"), "-q"))
    print(f"segment, whole file (16 k-means depots): {wall:6.1f} s, peak {mem:6.0f} MiB")
    hubs = tmp / "hubs.json"
    wall, mem = run(
        marops("segment", str(path), "--hubs", "auto", "--dates", history, "--out", str(hubs), "-q")
    )
    doc = json.loads(hubs.read_text())
    share = sum(h["share"] for h in doc["hubs"])
    print(
        f"segment --hubs auto:                     {wall:6.1f} s, peak {mem:6.0f} MiB "
        f"({len(doc['hubs'])} hubs holding {100 * share:.1f} % of the history's orders)"
    )
    for label, cache in (("first run", "fresh"), ("again, depots cached", "same")):
        env = dict(os.environ, MAROPS_CACHE_DIR=str(tmp / "cache"))
        out = tmp / f"city-{cache}"
        wall, mem = run(
            marops(
                "replay-day", str(path), "--date", day, "--hubs", str(hubs), "--out", str(out), "-q"
            ),
            env,
        )
        c = json.loads((out / "metrics.json").read_text())["city"]
        print(
            f"replay-day --hubs, one day ({label}): {wall:6.1f} s, peak {mem:6.0f} MiB; "
            f"{c['planned']:,} of {c['orders_due']:,} orders planned "
            f"({100 * c['covered_share']:.1f} %), {c['delivered']:,} delivered"
        )


def city_day(repeats: int, tmp: Path, smoke: bool = False) -> None:
    """The default run on a city's export: one day of a polycentric city of some 6,000
    orders a day replayed over the hubs it places (``replay-day`` as the README's first
    command runs it, 2 workers), first with an empty depots cache, then again with the
    hubs' depots cached; min and median of ``repeats``."""
    from marops_cli.data.synth import SynthConfig, generate, write

    per_day, days = (800.0, 2) if smoke else (6000.0, 4)
    path = tmp / "cityday.csv"
    write(
        generate(SynthConfig(days=days, seed=11, orders_per_day=per_day, shape="polycentric")), path
    )
    day = f"08{days:02d}"
    walls: dict[str, list[float]] = {"fresh": [], "cached": []}
    city: dict[str, Any] = {}
    for k in range(repeats):
        for label in ("fresh", "cached"):
            env = dict(os.environ, MAROPS_CACHE_DIR=str(tmp / f"cityday-cache-{k}"))
            out = tmp / f"cityday-{k}-{label}"
            cmd = marops(
                "replay-day", str(path), "--date", day, "--workers", "2", "--out", str(out), "-q"
            )
            wall, _ = run(cmd, env)
            walls[label].append(wall)
            city = json.loads((out / "metrics.json").read_text())["city"]
    due, inh = city["orders_due"], city["orders_due"] - city["outside_hours"]
    share = 100 * city["planned"] / max(inh, 1)
    print(
        f"replay-day, a city day (default: the whole export, {len(city['hubs'])} hubs, "
        f"{due:,} orders due, {city['planned']:,} planned = {share:.1f} % "
        f"of those in service hours), 2 workers:"
    )
    for label, w in walls.items():
        print(
            f"  {label:6s} depots: min {min(w):.1f} s, "
            f"median {statistics.median(w):.1f} s over {len(w)} runs"
        )


def repeated(repeats: int, tmp: Path, smoke: bool = False) -> None:
    depots = tmp / "depots.json"
    run(marops("segment", str(EXAMPLE), "--dates", "0801..0810", "--out", str(depots), "-q"))
    walls = []
    for i in range(repeats):
        w, mem = run(
            marops(
                "replay-day",
                str(EXAMPLE),
                "--date",
                "0811",
                "--depots",
                str(depots),
                "--out",
                str(tmp / f"one{i}"),
                "-q",
            )
        )
        walls.append(w)
    print(
        f"replay-day, one day with --depots: median {statistics.median(walls):.2f} s, "
        f"min {min(walls):.2f} s over {repeats} runs, peak {mem:.0f} MiB"
    )
    r = subprocess.run(
        [sys.executable, "-c", _STAGES, str(EXAMPLE), str(depots), str(tmp)],
        capture_output=True,
        text=True,
        check=True,
    )
    stages = json.loads(r.stdout.strip().splitlines()[-1])
    print(
        "  stages of one run, in one process: "
        + "; ".join(f"{k} {v:.2f} s" for k, v in stages.items())
    )

    def dates(span: str, i: int, *extra: str) -> float:
        out = tmp / f"d-{span.replace('..', '-')}-{'-'.join(extra)}-{i}"
        cmd = ["replay-day", str(EXAMPLE), "--dates", span, "--depots", str(depots)]
        return run(marops(*cmd, *extra, "--out", str(out), "-q"))[0]

    # The marginal day: from 2 days to all 12 of the example (both on workers, so the
    # workers' start is in both and cancels), with the default 2 workers and with 1;
    # and, as before, 5 days against 1 (which plans in the command's own process).
    many, n_many, few, n_few = (
        ("0810..0812", 3, "0811..0812", 2) if smoke else ("0801..0812", 12, "0808..0812", 5)
    )
    few_label = f"{n_few} vs 1 day"
    slopes: dict[str, list[float]] = {"2 workers": [], "1 worker": [], few_label: []}
    for i in range(1 if smoke else max(2, repeats // 2)):
        for label, extra in (("2 workers", ()), ("1 worker", ("--workers", "1"))):
            two = dates("0811..0812", i, *extra)
            all_days = dates(many, i, *extra)
            slopes[label].append((all_days - two) / (n_many - 2))
        one = dates("0811", i)
        some = dates(few, i)
        slopes[few_label].append((some - one) / (n_few - 1))
    print(
        "each extra day of --dates: "
        + "; ".join(
            f"{k} median {statistics.median(v):.2f} s, min {min(v):.2f} s"
            for k, v in slopes.items()
        )
        + f" ({n_many} days minus 2 days, / {n_many - 2}; {n_few} days minus 1 day, "
        f"/ {n_few - 1})"
    )


def sweep(tmp: Path, smoke: bool = False) -> None:
    from marops_cli.data.synth import SynthConfig, generate, write

    path = tmp / "sweep.csv"
    write(generate(SynthConfig(days=12 if smoke else 40, seed=9)), path)
    methods, dates, n_days = (
        ("greedy,stay", "0812", 1) if smoke else ("marops,ops-global,greedy,stay", "0811..0909", 30)
    )
    walls = {}
    for workers in (1, 2):
        out = tmp / f"ev{workers}"
        t = time.perf_counter()
        r = subprocess.run(
            marops(
                "evaluate",
                str(path),
                "--methods",
                methods,
                "--dates",
                dates,
                "--area",
                "square",
                "--workers",
                str(workers),
                "--no-plot",
                "--out",
                str(out),
                "-q",
            ),
            capture_output=True,
            text=True,
            check=False,
        )
        walls[workers] = time.perf_counter() - t
        if r.returncode:
            raise SystemExit(r.stderr)
    print(
        f"evaluate, {n_days} days x {len(methods.split(','))} methods: --workers 1 "
        f"{walls[1]:.1f} s, --workers 2 {walls[2]:.1f} s: {walls[1] / walls[2]:.2f}x faster"
    )


def calibration() -> float:
    """Seconds a fixed pure-Python workload takes now, in a fresh process (min of 3):
    how busy the shared machine is while the figures are taken."""
    code = "import time; t = time.perf_counter(); sum(i * i for i in range(3_000_000)); "
    code += "print(time.perf_counter() - t)"
    return min(
        float(
            subprocess.run(
                [sys.executable, "-c", code], capture_output=True, text=True, check=True
            ).stdout
        )
        for _ in range(3)
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--city", action="store_true", help="the city file's figures")
    ap.add_argument("--rows", type=int, default=1_500_000)
    ap.add_argument("--sweep", action="store_true", help="evaluate with 1 and 2 workers")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--smoke", action="store_true", help="every part once, least input (CI)")
    args = ap.parse_args()
    if args.smoke:
        args.repeats, args.city, args.sweep, args.rows = 1, True, True, 2000
    before = calibration()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        os.environ.setdefault("MAROPS_CACHE_DIR", str(tmp / "cache"))
        repeated(args.repeats, tmp, args.smoke)
        city_day(args.repeats, tmp, args.smoke)
        if args.city:
            city(args.rows, tmp, *((1000.0, 8.0) if args.smoke else (8300.0, 40.0)))
        if args.sweep:
            sweep(tmp, args.smoke)
    print(
        f"machine: a fixed Python loop took {before:.3f} s before and {calibration():.3f} s "
        "after (larger: a busier machine)"
    )


if __name__ == "__main__":
    main()
