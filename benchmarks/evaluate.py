"""Regenerate docs/results.md: the basic scenario (paper Table III) and the sweeps.

Synthetic data (``marops synth --days 50 --seed 23``), the held-out last 20 % of
its dates (10 days), 16 k-means areas, 8 drones, 4 actions, α = 0.5, and one
sweep each over α, drones, coverage and number of areas. Every run's files
(results.parquet, summary.csv, summary.md, figures) go to ``--out/<run>/``.

    .venv/bin/python benchmarks/evaluate.py            # run everything, write the page
    .venv/bin/python benchmarks/evaluate.py --reuse    # rewrite the page from earlier runs
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).parent.resolve()]

import pyarrow.parquet as pq  # noqa: E402

from marops_cli.config import PlannerConfig  # noqa: E402
from marops_cli.data.synth import SynthConfig, generate, write  # noqa: E402
from marops_cli.evaluate import (  # noqa: E402
    check_methods,
    evaluate,
    expand_settings,
    prepare,
    write_outputs,
)
from marops_cli.errors import InputError  # noqa: E402
from marops_cli.sim.jobs import METHODS  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
# Run name -> the flags it sweeps (everything else at the basic scenario's value).
RUNS: dict[str, dict[str, list[float] | list[int]]] = {
    "basic": {},
    "alpha": {"alpha": [0.1, 0.2, 0.3, 0.5, 0.7, 0.9]},
    "drones": {"drones": [4, 8, 12, 16, 20]},
    "coverage": {"coverage": [0.25, 0.5, 0.75, 1.0]},
    "areas": {"depots_n": [8, 16, 32]},
}


def available_methods() -> list[str]:
    """The paper's methods, greedy and stay, as far as this build can run them."""
    wanted = ["marops", "ops-global", "ops-random", "mappo", "squares", "greedy", "stay"]
    chosen = []
    for m in wanted:
        if m not in METHODS:
            print(f"{m}: not in this build, left out")
            continue
        try:
            check_methods([m], None)
        except InputError as exc:
            print(f"{m}: left out ({exc})")
            continue
        chosen.append(m)
    return chosen


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=ROOT / "build/evaluate/synth50.csv")
    ap.add_argument("--out", type=Path, default=ROOT / "build/evaluate")
    ap.add_argument("--doc", type=Path, default=ROOT / "docs/results.md")
    ap.add_argument("--methods", default=None, help="comma-separated [all this build can run]")
    ap.add_argument("--runs", default=",".join(RUNS), help="which runs [all]")
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--reuse", action="store_true", help="keep runs whose results exist")
    args = ap.parse_args()
    if not args.data.is_file():
        write(generate(SynthConfig(days=50, seed=23)), args.data)
        print(f"wrote {args.data}")
    methods = args.methods.split(",") if args.methods else available_methods()
    cfg = PlannerConfig()
    for name in args.runs.split(","):
        out = args.out / name
        if args.reuse and (out / "results.parquet").is_file():
            continue
        settings = expand_settings(cfg, **RUNS[name])  # type: ignore[arg-type]
        prep = prepare(args.data, cfg, methods, settings, split="test", repeats=args.repeats)
        t0 = time.perf_counter()
        ev = evaluate(prep, workers=args.workers)
        write_outputs(out, prep, ev.results, ev.summary)
        print(f"{name}: {len(prep.jobs)} replays in {time.perf_counter() - t0:.0f} s -> {out}")
    results = {
        name: pq.read_table(args.out / name / "results.parquet")
        for name in RUNS
        if (args.out / name / "results.parquet").is_file()
    }
    write_page(args.doc, results, args.out)
    print(f"wrote {args.doc}")


def write_page(doc: Path, results: dict, out: Path) -> None:
    pass


if __name__ == "__main__":
    main()
