"""The learned actor against myopic on cities it never saw (not a test; prints tables).

Makes held-out cities with ``marops synth`` (seeds and shapes not used in training:
the shipped actor trained on seed 11), takes depots from each city's first
``--history`` days and replays the rest with both methods, for every (areas, drones)
setting and every α of the sweep. Prints, per city shape and setting, the paired
per-day difference actor − myopic (mean and bootstrap 95 % CI over days) of the day
objective J, delay, energy and delivered share; then the α sweep's energy/delay
points and whether myopic's dominates the actor's.

    python benchmarks/heldout.py                      # 4 shapes x 10 days, 16/25 areas, 8/16 drones
    python benchmarks/heldout.py --quick              # 2 shapes x 4 days, one setting
    python benchmarks/heldout.py --smoke              # 1 shape x 2 days, one setting (CI)

Work is spread over ``--workers`` processes (one thread each); results do not
depend on it.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

SHAPES = ("hubs", "river", "corridor", "polycentric")
SEEDS = {"hubs": 41, "river": 42, "corridor": 43, "polycentric": 44}
KEYS = ("objective_j_mj", "avg_delay_h", "mean_energy_kj", "delivered_share")
PER_PARCEL = "energy_per_parcel"  # mean_energy_kj / delivered_share: energy per parcel delivered
OPS_KEYS = ("battery_waits", "busy_windows", "stock_left_total", "stock_left_max", "charged_min")
BEST = "best rule"
"""The per-day best of the reference methods by day J (``--against``), a method of its own
in the paired tables: beating it on a day means beating every reference that day."""


def held_out_cities(shapes: list[str], days: int, prefix: str) -> dict[str, Path]:
    """One ``marops synth`` file per shape, seeds never used in training, in a new
    temporary folder: ``{shape: path}``."""
    from marops_cli.data.synth import SynthConfig, generate, write

    tmp = Path(tempfile.mkdtemp(prefix=prefix))
    return {
        s: write(
            generate(SynthConfig(days=days, seed=SEEDS[s], shape=s, start="2022-09-01")),
            tmp / f"{s}.csv",
        )
        for s in shapes
    }


def _job(task: tuple[Any, ...]) -> list[dict[str, Any]]:
    """Replay every test day of one (city, areas, drones, α, method)."""
    os.environ["OMP_NUM_THREADS"] = "1"
    import torch

    torch.set_num_threads(1)
    from marops_cli.config import PlannerConfig, load_config, override
    from marops_cli.data.reader import read_lade
    from marops_cli.methods import method as method_spec
    from marops_cli.sim.scenario import load_fleet, load_scenario, method_policy, replay

    path, shape, history, n_dep, drones, alpha, method, policy, config = task
    base = PlannerConfig() if config is None else load_config(Path(config))
    table = read_lade(path, base.data)
    days = table.days()[history:]
    cfg = override(
        base,
        segment__method=method_spec(method).segmentation,
        segment__n_depots=n_dep,
        sim__drones=drones,
        plan__alpha=alpha,
    )
    scn = load_scenario(path, cfg, replay_days=days, table=table)
    fleet = load_fleet(None, scn.depots, drones, cfg)
    learned = method_spec(method).policy == "learned"
    pol = method_policy(method, policy if learned else None, 0, ops=cfg.ops)
    rows = []
    for day in days:
        res, _, m = replay(scn, day, fleet, pol, method)
        rows.append(
            {
                "shape": shape,
                "n_depots": n_dep,
                "drones": drones,
                "alpha": alpha,
                "method": method,
                "day": str(m["day"]),
                **{k: float(m[k]) for k in KEYS},
                **{k: m[k] for k in OPS_KEYS if m.get(k) is not None},
                # The same day has the same drones and requests for every method, so this
                # ratio compares the energy each flies per parcel it delivers.
                PER_PARCEL: float(m["mean_energy_kj"]) / max(float(m["delivered_share"]), 1e-9),
                "choices": choices(res),
            }
        )
    return rows


def choices(res: Any) -> dict[str, int]:
    """How often each action index was flown (``free``: the free landing) by the drones
    that could fly (``sim.metrics.flown_actions``)."""
    from marops_cli.plans.view import FREE
    from marops_cli.sim.metrics import flown_actions

    out: dict[str, int] = {}
    for action in flown_actions(res):
        key = "free" if action == FREE else str(action)
        out[key] = out.get(key, 0) + 1
    return out


def _ci(d: np.ndarray) -> tuple[float, float, float]:
    from marops_cli.evaluate.paired import bootstrap_ci

    lo, hi = bootstrap_ci(d)
    return float(d.mean()), lo, hi


def paired(rows: list[dict[str, Any]], group: tuple[str, ...], a: str, b: str) -> list[dict]:
    """Per group, the per-day difference a − b of each metric: mean and 95 % CI."""
    out = []
    keys = sorted({tuple(r[g] for g in group) for r in rows})
    for key in keys:
        sel = [r for r in rows if tuple(r[g] for g in group) == key]
        by = {
            m: {
                (r["shape"], r["n_depots"], r["drones"], r["alpha"], r["day"]): r
                for r in sel
                if r["method"] == m
            }
            for m in (a, b)
        }
        common = sorted(set(by[a]) & set(by[b]))
        res: dict[str, Any] = dict(zip(group, key, strict=True))
        res["days"] = len(common)
        for k in (*KEYS, PER_PARCEL):
            d = np.array([by[a][c][k] - by[b][c][k] for c in common])
            res[k] = _ci(d)
            res[k + "_a"] = float(np.mean([by[a][c][k] for c in common]))
            res[k + "_b"] = float(np.mean([by[b][c][k] for c in common]))
        res["j_better_days"] = int(
            sum(by[a][c]["objective_j_mj"] < by[b][c]["objective_j_mj"] for c in common)
        )
        out.append(res)
    return out


def _fmt(ci: tuple[float, float, float], nd: int) -> str:
    m, lo, hi = ci
    star = " *" if (hi < 0 or lo > 0) else ""
    return f"{m:+.{nd}f} [{lo:+.{nd}f}, {hi:+.{nd}f}]{star}"


def _pct(g: dict[str, Any], key: str) -> str:
    """The paired difference of ``key`` as a percentage of the reference's mean."""
    base = g[key + "_b"]
    if not base:
        return "-"
    m, lo, hi = (100.0 * x / abs(base) for x in g[key])
    return _fmt((m, lo, hi), 1)


def print_paired(rows: list[dict[str, Any]], methods: tuple[str, ...], markdown: bool) -> None:
    """Per shape and setting, the actor minus each reference, paired per day (α 0.5)."""
    a, refs = methods[0], methods[1:]
    at05 = [r for r in rows if r["alpha"] == 0.5]
    sep = " | " if markdown else "  "
    head = ["shape", "areas", "drones", "days", "Δ day J MJ", "Δ J %", "Δ delay h",
            "Δ energy kJ/drone", "Δ energy %", "Δ energy per parcel %", "Δ delivered share",
            "J better"]  # fmt: skip
    for b in refs:
        print(f"\n{a} − {b}, paired per day, mean [95 % bootstrap CI] (* excludes 0), α = 0.5")
        if markdown:
            print("| " + " | ".join(head) + " |\n|" + "---|" * len(head))
        else:
            print(sep.join(head))
        groups = paired(at05, ("shape", "n_depots", "drones"), a, b)
        groups += [
            {**g, "n_depots": "all", "drones": "all"} for g in paired(at05, ("shape",), a, b)
        ]
        groups += [
            {**g, "shape": "all", "n_depots": "all", "drones": "all"}
            for g in paired([{**r, "all": 1} for r in at05], ("all",), a, b)
        ]
        for g in groups:
            cells = [
                str(g["shape"]), str(g["n_depots"]), str(g["drones"]), str(g["days"]),
                _fmt(g["objective_j_mj"], 2), _pct(g, "objective_j_mj"),
                _fmt(g["avg_delay_h"], 3), _fmt(g["mean_energy_kj"], 1),
                _pct(g, "mean_energy_kj"), _pct(g, PER_PARCEL), _fmt(g["delivered_share"], 4),
                f"{g['j_better_days']}/{g['days']}",
            ]  # fmt: skip
            print(("| " + " | ".join(cells) + " |") if markdown else sep.join(cells))


def with_best(rows: list[dict[str, Any]], refs: list[str]) -> list[dict[str, Any]]:
    """``rows`` plus, per (city, setting, α, day), the row of the reference with the lowest
    day J that day as method :data:`BEST` (its ``rule`` says which)."""
    out = list(rows)
    by: dict[tuple, list[dict[str, Any]]] = {}
    for r in rows:
        if r["method"] in refs:
            key = (r["shape"], r["n_depots"], r["drones"], r["alpha"], r["day"])
            by.setdefault(key, []).append(r)
    for group in by.values():
        if len(group) == len(refs):
            best = min(group, key=lambda r: r["objective_j_mj"])
            out.append({**best, "method": BEST, "rule": best["method"]})
    return out


def print_choices(rows: list[dict[str, Any]], method: str, markdown: bool) -> None:
    """Per shape, the share of each action ``method`` flew (α 0.5) and the largest."""
    print(f"\n{method}'s decisions per shape (share of each action; the largest must stay <= 0.9)")
    shapes = sorted({r["shape"] for r in rows})
    for shape in [*shapes, "all"]:
        total: dict[str, int] = {}
        for r in rows:
            if r["method"] == method and r["alpha"] == 0.5 and shape in ("all", r["shape"]):
                for k, n in r["choices"].items():
                    total[k] = total.get(k, 0) + n
        n = sum(total.values())
        if not n:
            continue
        shares = {k: total[k] / n for k in sorted(total, key=lambda k: (k == "free", k))}
        cells = ", ".join(f"{k}: {v:.3f}" for k, v in shares.items())
        line = f"{shape}: {n} decisions; {cells}; largest {max(shares.values()):.3f}"
        print(f"- {line}" if markdown else line)


def print_operations(rows: list[dict[str, Any]], methods: tuple[str, ...], markdown: bool) -> None:
    """Per method, what the operating model held back (α 0.5, mean per day): windows drones
    waited for a battery, parcels left at the depots at the day's end, the most at one."""
    if not any("battery_waits" in r for r in rows):
        return
    print(
        "\noperating model per method (mean per day): battery waits, busy drone-windows, "
        "parcels left at depots at the end, most at one depot, fewest spare batteries"
    )
    for m in methods:
        rs = [r for r in rows if r["method"] == m and r["alpha"] == 0.5]
        if not rs:
            continue
        cells = [f"{k} {np.mean([float(r.get(k) or 0) for r in rs]):.1f}" for k in OPS_KEYS]
        print(("- " if markdown else "") + f"{m}: " + ", ".join(cells))


def print_sweep(rows: list[dict[str, Any]], methods: tuple[str, ...], markdown: bool) -> None:
    """The α sweep's mean energy/delay point of every method per shape (and over all), and
    which reference dominates the actor's point (no more energy and no more delay, one
    of them less)."""
    a, refs = methods[0], methods[1:]
    sweep = [r for r in rows if r["n_depots"] == 16 and r["drones"] == 8]
    shapes = [*sorted({r["shape"] for r in sweep}), "all"]
    print("\nα sweep (16 areas, 8 drones): energy kJ/drone, delay h, day J MJ, delivered share")
    if markdown:
        print("| shape | α | " + " | ".join(methods) + " | actor dominated by |")
        print("|" + "---|" * (len(methods) + 3))
    for shape in shapes:
        for al in sorted({r["alpha"] for r in sweep}):
            pts = {}
            for m in methods:
                rs = [
                    r
                    for r in sweep
                    if r["alpha"] == al and r["method"] == m and shape in ("all", r["shape"])
                ]
                pts[m] = tuple(
                    float(np.mean([r[k] for r in rs]))
                    for k in ("mean_energy_kj", "avg_delay_h", "objective_j_mj", "delivered_share")
                )
            ea, da = pts[a][:2]
            dom = [
                b
                for b in refs
                if pts[b][0] <= ea and pts[b][1] <= da and (pts[b][0] < ea or pts[b][1] < da)
            ]
            cells = [f"{p[0]:.0f} kJ, {p[1]:.3f} h, J {p[2]:.1f}, {p[3]:.3f}" for p in pts.values()]
            if markdown:
                print(
                    f"| {shape} | {al:.1f} | "
                    + " | ".join(cells)
                    + f" | {', '.join(dom) or 'none'} |"
                )
            else:
                print(
                    f"{shape:12s} α {al:.1f}  "
                    + "  ".join(f"{m}: {c}" for m, c in zip(methods, cells, strict=True))
                    + f"  dominated by: {', '.join(dom) or 'none'}"
                )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shapes", default=",".join(SHAPES))
    ap.add_argument(
        "--days", type=int, default=14, help="days per city (the first --history only give depots)"
    )
    ap.add_argument("--history", type=int, default=4)
    ap.add_argument("--depots", default="16,25")
    ap.add_argument("--drones", default="8,16")
    ap.add_argument("--alphas", default="0.2,0.5,0.8", help="α sweep (16 areas, 8 drones)")
    ap.add_argument("--policy", default=None, help="actor file [the shipped one]")
    ap.add_argument(
        "--config", default=None, help="config TOML, e.g. an operating model [the defaults]"
    )
    ap.add_argument(
        "--against",
        default="myopic",
        help="reference methods, comma-separated (myopic,ops-global; under the realistic "
        "model the landing rules ops-global,backlog,rebalance,flow,battery)",
    )
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--quick", action="store_true", help="2 shapes x 6 days, 16 areas, 8 drones")
    ap.add_argument("--smoke", action="store_true", help="1 shape x 2 days, one setting (CI)")
    ap.add_argument("--json", default=None, help="also write every day's row here")
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args()
    if args.quick:
        args.shapes, args.days, args.depots, args.drones, args.alphas = (
            "hubs,river", 8, "16", "8", "0.5",
        )  # fmt: skip
    if args.smoke:
        args.shapes, args.days, args.depots, args.drones, args.alphas = (
            "hubs", args.history + 2, "16", "8", "0.5",
        )  # fmt: skip
    shapes = [s for s in args.shapes.split(",") if s]
    depots = [int(x) for x in args.depots.split(",")]
    drones = [int(x) for x in args.drones.split(",")]
    alphas = [float(x) for x in args.alphas.split(",")]
    files = held_out_cities(shapes, args.days, "marops-heldout-")
    refs = [m for m in args.against.split(",") if m]
    methods = ("marops", *refs)
    tasks = []
    for s in shapes:
        for n in depots:
            for u in drones:
                for m in methods:
                    tasks.append(
                        (str(files[s]), s, args.history, n, u, 0.5, m, args.policy, args.config)
                    )
        for a in alphas:
            if a == 0.5 and 16 in depots and 8 in drones:
                continue  # already in the settings above
            for m in methods:
                tasks.append(
                    (str(files[s]), s, args.history, 16, 8, a, m, args.policy, args.config)
                )
    t0 = time.perf_counter()
    with mp.get_context("spawn").Pool(args.workers) as pool:
        rows = [r for part in pool.map(_job, tasks, chunksize=1) for r in part]
    print(f"{len(rows)} day replays in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    if len(refs) > 1:
        rows = with_best(rows, refs)
        print_paired(rows, ("marops", BEST, *refs), args.markdown)
        print_sweep(rows, ("marops", *refs), args.markdown)
    else:
        print_paired(rows, methods, args.markdown)
        print_sweep(rows, methods, args.markdown)
    print_choices(rows, "marops", args.markdown)
    print_operations(rows, methods, args.markdown)


if __name__ == "__main__":
    main()
