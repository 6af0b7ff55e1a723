"""Held-out comparison of the shipped actors with the baselines (not a test; prints a table).

Replays every evaluation day with every method (8 drones, 16 depots by default)
and prints mean ± std over days. The daily combined cost (docs/method.md §8) is the
combined cost of each day over the methods compared in this run (mean of energy / max
energy and delay / max delay that day), then averaged over days.

Depots come from the file's first ``--history`` days; the remaining days are
evaluated, so neither the depots nor the actors (trained on another file) ever
saw them. The table in ``policies/README.md`` was made with::

    marops synth --days 14 --seed 23 --start 2022-09-01 --out /tmp/heldout.csv
    python benchmarks/train.py --data /tmp/heldout.csv --history 4 --markdown
    python benchmarks/train.py --data /tmp/heldout.csv --history 4 --markdown --planner subsets

``--time-training N`` instead times ``marops train`` for N episodes on the basic
scenario (8 drones, 16 areas, a 20-day ``marops synth --seed 11`` file, 2 workers;
held-out evaluations every 200 episodes included) and prints the figure:

    python benchmarks/train.py --time-training 2000
    python benchmarks/train.py --time-training 2000 --algorithm es   # the landing actor

``--smoke`` runs both on the least input (2 training episodes on one worker; the table
over one held-out day), so CI sees the script keep up with the library.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
PAPER_OPS = Path(__file__).resolve().parents[1] / "examples" / "paper-ops.toml"

from marops_cli.config import OpsConfig, PlannerConfig, override  # noqa: E402
from marops_cli.data.reader import read_lade  # noqa: E402
from marops_cli.methods import method as method_spec  # noqa: E402
from marops_cli.rl.evaluate import method_table  # noqa: E402
from marops_cli.sim.scenario import load_fleet, load_scenario, method_policy, replay  # noqa: E402

DEFAULT_METHODS = "marops,squares,mappo,ops-random,greedy,ops-global,stay,myopic"
COLUMNS = (
    ("mean_energy_kj", "energy kJ/drone", "{:.1f} ± {:.1f}"),
    ("avg_delay_h", "avg delay h", "{:.3f} ± {:.3f}"),
    ("daily_combined_cost", "daily combined cost", "{:.3f} ± {:.3f}"),
    ("delay_unfairness", "unfairness", "{:.3f} ± {:.3f}"),
    ("avg_early_h", "early h", "{:.3f} ± {:.3f}"),
    ("delivered", "delivered", "{:.0f} ± {:.0f}"),
    ("delivered_share", "delivered share", "{:.3f} ± {:.3f}"),
    ("objective_j_mj", "day J MJ", "{:.1f} ± {:.1f}"),
    ("objective_g_mj", "day G MJ", "{:.1f} ± {:.1f}"),
)


def run(args: argparse.Namespace) -> dict[str, dict[str, tuple[float, float]]]:
    base = PlannerConfig(ops=OpsConfig.paper_model())  # the paper's actors' model
    table = read_lade(args.data, base.data)
    days = table.days()[args.history :]
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    rows = []
    for m in methods:
        cfg = override(
            base,
            segment__method=method_spec(m).segmentation,
            segment__n_depots=args.depots_n,
            sim__drones=args.drones,
            plan__alpha=args.alpha,
            plan__planner=args.planner,
        )
        scn = load_scenario(args.data, cfg, replay_days=days, table=table)
        fleet = load_fleet(None, scn.depots, cfg.sim.drones, cfg)
        pol = method_policy(
            m,
            args.policy if method_spec(m).policy == "learned" else None,
            cfg.sim.seed,
            ops=cfg.ops,
        )
        t0 = time.perf_counter()
        for day in days:
            _, _, metrics = replay(scn, day, fleet, pol, m)
            rows.append(metrics)
        print(f"{m}: {len(days)} days in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return method_table(rows)


def time_training(episodes: int, workers: int, smoke: bool = False, algorithm: str = "ppo") -> None:
    """Train an actor for ``episodes`` on the basic scenario; print the time (``smoke``: on
    5 days of a third of the orders, the least that trains). ``ppo``: the recurrent actor
    under the paper's operating model; ``es``: the landing actor under the default one."""
    import json
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory(prefix="marops-train-time-") as d:
        data = Path(d) / "train.csv"
        out = Path(d) / ("a.safetensors" if algorithm == "es" else "a.pt")
        how = ["--algorithm", "es"] if algorithm == "es" else ["--config", str(PAPER_OPS)]
        exe = Path(sys.executable).with_name("marops")  # the venv's entry point
        marops = [str(exe) if exe.exists() else "marops"]
        size = ["--days", "5", "--orders-per-day", "600"] if smoke else ["--days", "20"]
        subprocess.run([*marops, "synth", *size, "--seed", "11", "--out", str(data)], check=True)
        cmd = [*marops, "train", str(data), "--episodes", str(episodes), "--workers",
               str(workers), "--no-resume", "--out", str(out), *how]  # fmt: skip
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        wall = time.perf_counter() - t0
        side = json.loads(out.with_suffix(".json").read_text())
    print(
        f"marops train --algorithm {algorithm}, {episodes} episodes, {workers} workers: "
        f"{wall:.0f} s wall "
        f"({wall / 60:.1f} min, {wall / episodes:.3f} s per episode); "
        f"training_time_s {side['training_time_s']:.0f} s (rollouts, updates, evaluations)"
    )


def print_table(args: argparse.Namespace) -> None:
    """Replay the held-out days of ``args.data`` with every method; print the table."""
    table = run(args)
    head = ["method", *[c[1] for c in COLUMNS]]
    lines = [[m, *[fmt.format(*t[k]) for k, _, fmt in COLUMNS]] for m, t in table.items()]
    if args.markdown:
        print("| " + " | ".join(head) + " |")
        print("|" + "---|" * len(head))
        for ln in lines:
            print("| " + " | ".join(ln) + " |")
    else:
        widths = [max(len(r[i]) for r in [head, *lines]) for i in range(len(head))]
        for r in [head, *lines]:
            print("  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)))


def smoke(args: argparse.Namespace) -> None:
    """Both parts on the least input: 2 training episodes on one worker, then the table
    over the one held-out day of a ``marops synth --seed 23 --start 2022-09-01`` file
    with a third of the orders."""
    import datetime as dt
    import tempfile

    from marops_cli.data.synth import SynthConfig, generate, write

    time_training(2, 1, smoke=True)
    time_training(2, 1, smoke=True, algorithm="es")
    with tempfile.TemporaryDirectory(prefix="marops-train-smoke-") as d:
        start = dt.date(2022, 9, 1)
        cfg = SynthConfig(days=args.history + 1, seed=23, start=start, orders_per_day=600.0)
        args.data = str(write(generate(cfg), Path(d) / "heldout.csv"))
        print_table(args)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--time-training", type=int, default=0, metavar="N",
                    help="time marops train for N episodes instead")  # fmt: skip
    ap.add_argument("--workers", type=int, default=2, help="--time-training: rollout workers")
    ap.add_argument(
        "--algorithm", default="ppo", choices=["ppo", "es"], help="--time-training: which actor"
    )
    ap.add_argument("--data", help="LaDe-shaped CSV (e.g. marops synth --seed 23)")
    ap.add_argument("--history", type=int, default=4, help="first days used only for depots")
    ap.add_argument("--methods", default=DEFAULT_METHODS)
    ap.add_argument("--drones", type=int, default=8)
    ap.add_argument("--depots-n", type=int, default=16)
    ap.add_argument("--alpha", type=float, default=0.5)
    ap.add_argument(
        "--planner", default="pool", choices=["pool", "subsets"], help="[plan] planner [pool]"
    )
    ap.add_argument("--policy", default=None, help="actor for marops/squares [the shipped one]")
    ap.add_argument("--markdown", action="store_true", help="print a Markdown table")
    ap.add_argument("--smoke", action="store_true", help="2 episodes; 1 day's table (CI)")
    args = ap.parse_args()
    if args.smoke:
        smoke(args)
    elif args.time_training:
        time_training(args.time_training, args.workers, algorithm=args.algorithm)
    elif not args.data:
        ap.error("--data is required (or --time-training N)")
    else:
        print_table(args)


if __name__ == "__main__":
    main()
