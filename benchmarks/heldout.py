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
depend on it. A line on stderr per finished job (one city, setting and method).

**The generalisation grid** (``--grid``, or any of ``--batteries`` and ``--load``):
the shipped landing actor (``marops``) against the day's best rule (the one of
``--against``, by default ``ops-global,backlog,rebalance,flow,battery``, with the
lowest day J that day) over drones × areas × batteries × load, on the held-out cities
(seeds 41–44, four shapes; the actor trained on seed 11), at α 0.5::

    python benchmarks/heldout.py --grid --markdown --json grid.json   # hours on 2 cores
    python benchmarks/heldout.py --drones 8 --depots 16 --batteries scarce,ample --load 1,3
    python benchmarks/heldout.py --smoke --batteries scarce --load 3  # tiny, both new axes

``--grid`` is drones 4,8,16,32 × areas 16,25,36 × batteries scarce,default,ample ×
load 1,3 (explicit ``--drones``, ``--depots``, ``--batteries``, ``--load`` replace its
axis). Batteries (``marops_cli.config.BATTERY_PRESETS``, the ``[ops]`` options each preset
sets; the regimes ``marops train --batteries`` trains on):

    =========  ===================  ==================  ==============
    preset     batteries_per_depot  chargers_per_depot  charge_power_w
    =========  ===================  ==================  ==============
    scarce     1                    1                   31
    default    the config's (2)     the config's (1)    the config's (62.5)
    ample      4                    2                   125
    =========  ===================  ==================  ==============

Load ``×k`` replays a city synthesised with the same seed, shape and days and ``k``
times the default ``orders_per_day`` (a file of its own per load). One row per setting
(drones, areas, batteries, load; every shape's days pooled), marops − the day's best
rule paired per day, mean [bootstrap 95 % CI] (``*``: the interval excludes 0):
``Δ J %`` (of the best rule's mean day J), ``Δ energy %`` (energy per drone),
``kJ/parcel`` (the day's flown energy over the parcels delivered, summed over the
days: marops / best rule), ``Δ per parcel %`` (per day: energy per drone over the
delivered share), ``Δ delivered pts`` (delivered share, in points), ``J better``
(days marops's J is lower), ``best rule`` (the rule best on most days, and on how
many), and marops's action mix: ``top`` (the share of its commonest action: stay, a
destination by its index, or the free landing), ``stay``, ``move``, ``free`` (shares
of its decisions, counted per drone that could fly in each window as
``sim.metrics.flown_actions`` yields them, pooled over the setting's days). A last
row pools the whole grid, and a line counts the settings whose J interval lies below
and above 0. ``--json`` writes ``{"run": the run's options, "settings": the table's
rows, "rows": every day's row}`` (without the grid: the list of rows, as ever). The
per-shape tables and the α sweep of the plain run are not printed for the grid.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from marops_cli.config import BATTERY_PRESETS, battery_preset  # noqa: E402

SHAPES = ("hubs", "river", "corridor", "polycentric")
SEEDS = {"hubs": 41, "river": 42, "corridor": 43, "polycentric": 44}
KEYS = ("objective_j_mj", "avg_delay_h", "mean_energy_kj", "delivered_share")
PER_PARCEL = "energy_per_parcel"  # mean_energy_kj / delivered_share: energy per parcel delivered
OPS_KEYS = ("battery_waits", "busy_windows", "stock_left_total", "stock_left_max", "charged_min")
RULES = "ops-global,backlog,rebalance,flow,battery"
"""The grid's reference rules (``--against`` unless given)."""
GRID = {"drones": "4,8,16,32", "depots": "16,25,36", "batteries": "scarce,default,ample",
        "load": "1,3"}  # fmt: skip
"""``--grid``: every axis of the generalisation benchmark."""
SETTING = ("drones", "n_depots", "batteries", "load")
"""What a row of the grid's table is per: every shape's days pooled."""
BEST = "best rule"
"""The per-day best of the reference methods by day J (``--against``), a method of its own
in the paired tables: beating it on a day means beating every reference that day."""


def held_out_cities(
    shapes: list[str], days: int, prefix: str, loads: tuple[float, ...] = (1.0,)
) -> dict[tuple[str, float], Path]:
    """One ``marops synth`` file per shape and load (``orders_per_day`` times the
    default), seeds never used in training, in a new temporary folder:
    ``{(shape, load): path}``."""
    from marops_cli.data.synth import SynthConfig, generate, write

    tmp = Path(tempfile.mkdtemp(prefix=prefix))
    orders = SynthConfig().orders_per_day
    out = {}
    for s in shapes:
        for k in loads:
            cfg = SynthConfig(
                days=days, seed=SEEDS[s], shape=s, start="2022-09-01", orders_per_day=orders * k
            )
            out[(s, k)] = write(generate(cfg), tmp / (f"{s}.csv" if k == 1 else f"{s}-x{k:g}.csv"))
    return out


def _floats(text: str, option: str) -> list[float]:
    """A comma-separated list of positive numbers (``--load``)."""
    try:
        out = [float(x) for x in text.split(",") if x]
    except ValueError:
        out = []
    if not out or any(not (0 < x < 1e6) for x in out):
        raise ValueError(f"{option} expects positive numbers, comma-separated, got {text!r}")
    return out


def _names(text: str, option: str, allowed: dict[str, Any]) -> list[str]:
    """A comma-separated list of names out of ``allowed`` (``--batteries``)."""
    out = [x for x in text.split(",") if x]
    bad = [x for x in out if x not in allowed]
    if not out or bad:
        raise ValueError(f"{option} expects some of {', '.join(allowed)}, got {text!r}")
    return out


def _run(item: tuple[int, tuple[Any, ...]]) -> tuple[int, list[dict[str, Any]], float]:
    """:func:`_job` on the ``i``-th task: ``(i, rows, seconds)``."""
    i, task = item
    t0 = time.perf_counter()
    rows = _job(task)
    return i, rows, time.perf_counter() - t0


def _job(task: tuple[Any, ...]) -> list[dict[str, Any]]:
    """Replay every test day of one (city, areas, drones, α, method, batteries, load)."""
    os.environ["OMP_NUM_THREADS"] = "1"
    import torch

    torch.set_num_threads(1)
    from marops_cli.config import PlannerConfig, load_config, override
    from marops_cli.data.reader import read_lade
    from marops_cli.methods import method as method_spec
    from marops_cli.sim.scenario import load_fleet, load_scenario, method_policy, replay

    path, shape, history, n_dep, drones, alpha, method, policy, config, batteries, load = task
    base = PlannerConfig() if config is None else load_config(Path(config))
    base = override(base, **battery_preset(batteries))
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
        res, _, record = replay(scn, day, fleet, pol, method)
        m: dict[str, Any] = record
        rows.append(
            {
                "shape": shape,
                "n_depots": n_dep,
                "drones": drones,
                "alpha": alpha,
                "method": method,
                "batteries": batteries,
                "load": load,
                "day": str(m["day"]),
                **{k: float(m[k]) for k in KEYS},
                "energy_kj": float(m["energy_kj"]),
                "delivered": int(m["delivered"]),
                "requests": int(m["requests"]),
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


def _day(r: dict[str, Any]) -> tuple[Any, ...]:
    """What makes a day the same for every method: city, setting, α and date."""
    return (r["shape"], r["n_depots"], r["drones"], r.get("batteries", "default"),
            r.get("load", 1.0), r["alpha"], r["day"])  # fmt: skip


def paired(rows: list[dict[str, Any]], group: tuple[str, ...], a: str, b: str) -> list[dict]:
    """Per group, the per-day difference a − b of each metric: mean and 95 % CI."""
    out = []
    keys = sorted({tuple(r[g] for g in group) for r in rows})
    for key in keys:
        sel = [r for r in rows if tuple(r[g] for g in group) == key]
        by = {m: {_day(r): r for r in sel if r["method"] == m} for m in (a, b)}
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
            by.setdefault(_day(r), []).append(r)
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


def grid_pairs(
    rows: list[dict[str, Any]], a: str = "marops", b: str = BEST
) -> dict[tuple[Any, ...], list[tuple[dict[str, Any], dict[str, Any]]]]:
    """Per setting (:data:`SETTING`, in the grid's order), the rows of ``a`` and ``b`` of
    every day both flew at α 0.5, every shape's days together."""
    ref = {_day(r): r for r in rows if r["method"] == b and r["alpha"] == 0.5}
    out: dict[tuple[Any, ...], list[tuple[dict[str, Any], dict[str, Any]]]] = {}
    for r in rows:
        if r["method"] == a and r["alpha"] == 0.5 and _day(r) in ref:
            out.setdefault(tuple(r[k] for k in SETTING), []).append((r, ref[_day(r)]))
    order = list(BATTERY_PRESETS)

    def rank(key: tuple[Any, ...]) -> tuple[Any, ...]:
        drones, n_dep, batteries, load = key
        return drones, n_dep, order.index(batteries) if batteries in order else len(order), load

    return {k: out[k] for k in sorted(out, key=rank)}


def summarise(pairs: list[tuple[dict[str, Any], dict[str, Any]]]) -> dict[str, Any]:
    """One row of the grid's table from the (marops, best rule) rows of its days: the
    paired differences (mean and 95 % CI; ``*_pct`` of the best rule's mean, ``delivered_pts``
    in points of share), energy per delivered parcel of each (``kj_per_parcel``: flown
    energy over parcels delivered, summed over the days), days marops's J is lower, the
    rule best on most days, and marops's action mix (shares of its decisions)."""
    a = [p[0] for p in pairs]
    b = [p[1] for p in pairs]

    def diff(k: str) -> np.ndarray:
        return np.array([float(x[k]) - float(y[k]) for x, y in pairs])

    def pct(k: str) -> tuple[float, ...]:
        base = abs(float(np.mean([float(y[k]) for y in b])))
        return tuple(100.0 * v / base for v in _ci(diff(k))) if base else (np.nan,) * 3

    def per_parcel(rs: list[dict[str, Any]]) -> float:
        parcels = sum(r["delivered"] for r in rs)
        return sum(r["energy_kj"] for r in rs) / parcels if parcels else float("nan")

    counts: Counter[str] = Counter()
    for r in a:
        counts.update(r["choices"])
    n = sum(counts.values())
    stay, free = counts.get("0", 0), counts.get("free", 0)
    top, top_n = min(counts.items(), key=lambda kv: (-kv[1], kv[0])) if n else ("-", 0)
    rules = Counter(r.get("rule", r["method"]) for r in b)
    rule, rule_days = min(rules.items(), key=lambda kv: (-kv[1], kv[0])) if rules else ("-", 0)
    return {
        "days": len(pairs),
        "j_mj": _ci(diff("objective_j_mj")),
        "j_pct": pct("objective_j_mj"),
        "energy_pct": pct("mean_energy_kj"),
        "per_parcel_pct": pct(PER_PARCEL),
        "kj_per_parcel": (per_parcel(a), per_parcel(b)),
        "delivered_pts": tuple(100.0 * v for v in _ci(diff("delivered_share"))),
        "j_better_days": int(sum(x["objective_j_mj"] < y["objective_j_mj"] for x, y in pairs)),
        "best_rule": rule,
        "best_rule_days": rule_days,
        "decisions": n,
        "top_action": "stay" if top == "0" else top,
        "top_share": top_n / n if n else float("nan"),
        "stay": stay / n if n else float("nan"),
        "move": (n - stay - free) / n if n else float("nan"),
        "free": free / n if n else float("nan"),
    }


def grid_table(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The grid's table: one :func:`summarise` row per setting, then one over them all
    (``drones`` etc. ``all``)."""
    groups = grid_pairs(rows)
    out = [
        {**dict(zip(SETTING, key, strict=True)), **summarise(pairs)}
        for key, pairs in groups.items()
    ]
    if groups:
        every = [p for pairs in groups.values() for p in pairs]
        out.append({**dict.fromkeys(SETTING, "all"), **summarise(every)})
    return out


def print_grid(table: list[dict[str, Any]], refs: list[str], markdown: bool) -> None:
    """The grid's table (:func:`grid_table`) and how many settings marops wins."""
    head = ["drones", "areas", "batteries", "load", "days", "Δ J %", "Δ energy %",
            "kJ/parcel", "Δ per parcel %", "Δ delivered pts", "J better", "best rule", "top",
            "stay", "move", "free"]  # fmt: skip
    print(
        f"\nmarops − the day's best rule of {', '.join(refs)}, paired per day, α 0.5, every "
        "shape's days; mean [95 % bootstrap CI] (* excludes 0); marops's action mix"
    )
    sep = " | " if markdown else "  "
    if markdown:
        print("| " + " | ".join(head) + " |\n|" + "---|" * len(head))
    else:
        print(sep.join(head))
    for g in table:
        load = g["load"] if g["load"] == "all" else f"×{g['load']:g}"
        ea, eb = g["kj_per_parcel"]
        cells = [
            str(g["drones"]), str(g["n_depots"]), str(g["batteries"]), load, str(g["days"]),
            _fmt(g["j_pct"], 1), _fmt(g["energy_pct"], 1), f"{ea:.1f} / {eb:.1f}",
            _fmt(g["per_parcel_pct"], 1), _fmt(g["delivered_pts"], 1),
            f"{g['j_better_days']}/{g['days']}", f"{g['best_rule']} {g['best_rule_days']}",
            f"{g['top_share']:.3f} ({g['top_action']})", f"{g['stay']:.3f}",
            f"{g['move']:.3f}", f"{g['free']:.3f}",
        ]  # fmt: skip
        print(("| " + " | ".join(cells) + " |") if markdown else sep.join(cells))
    settings = [g for g in table if g["drones"] != "all"]
    below = sum(g["j_pct"][2] < 0 for g in settings)
    above = sum(g["j_pct"][1] > 0 for g in settings)
    line = (
        f"settings: {len(settings)}; Δ J interval below 0 in {below}, above 0 in {above}, "
        f"containing 0 in {len(settings) - below - above}"
    )
    print(f"\n{line}" if not markdown else f"\n- {line}")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The options, every axis resolved: ``--grid``'s, ``--quick``'s and ``--smoke``'s
    sizes applied, ``grid`` (the generalisation benchmark: ``--grid``, ``--batteries`` or
    ``--load``), and the lists ``shape_list``, ``depot_list``, ``drone_list``,
    ``alpha_list``, ``battery_list``, ``load_list``, ``refs``."""
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--shapes", default=",".join(SHAPES))
    ap.add_argument(
        "--days", type=int, default=14, help="days per city (the first --history only give depots)"
    )
    ap.add_argument("--history", type=int, default=4)
    ap.add_argument("--depots", default=None, help="areas, comma-separated [16,25]")
    ap.add_argument("--drones", default=None, help="drones, comma-separated [8,16]")
    ap.add_argument(
        "--batteries",
        default=None,
        help=f"battery presets, comma-separated, of {', '.join(BATTERY_PRESETS)} (the grid)",
    )
    ap.add_argument(
        "--load", default=None, help="orders_per_day multipliers, comma-separated (the grid)"
    )
    ap.add_argument(
        "--grid",
        action="store_true",
        help="the generalisation grid: drones 4,8,16,32 x areas 16,25,36 x batteries "
        "scarce,default,ample x load 1,3 against the day's best rule",
    )
    ap.add_argument(
        "--alphas", default=None, help="α sweep (16 areas, 8 drones) [0.2,0.5,0.8; not the grid]"
    )
    ap.add_argument("--policy", default=None, help="actor file [the shipped one]")
    ap.add_argument(
        "--config", default=None, help="config TOML, e.g. an operating model [the defaults]"
    )
    ap.add_argument(
        "--against",
        default=None,
        help=f"reference methods, comma-separated [myopic; the grid: {RULES}] "
        f"(myopic,ops-global; under the realistic model the landing rules {RULES})",
    )
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--quick", action="store_true", help="2 shapes x 6 days, 16 areas, 8 drones")
    ap.add_argument("--smoke", action="store_true", help="1 shape x 2 days, one setting (CI)")
    ap.add_argument("--json", default=None, help="also write every day's row here")
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args(argv)
    args.grid_run = args.grid or args.batteries is not None or args.load is not None
    if args.grid_run and args.alphas is not None:
        ap.error("the grid runs at α 0.5: --alphas is the plain run's sweep")
    for axis, value in GRID.items():
        if getattr(args, axis) is None and args.grid:
            setattr(args, axis, value)
    args.depots = args.depots or "16,25"
    args.drones = args.drones or "8,16"
    args.alphas = "0.5" if args.grid_run else args.alphas or "0.2,0.5,0.8"
    args.against = args.against or (RULES if args.grid_run else "myopic")
    if args.quick:
        args.shapes, args.days, args.depots, args.drones, args.alphas = (
            "hubs,river", 8, "16", "8", "0.5",
        )  # fmt: skip
    if args.smoke:
        args.shapes, args.days, args.depots, args.drones, args.alphas = (
            "hubs", args.history + 2, "16", "8", "0.5",
        )  # fmt: skip
    try:
        args.battery_list = _names(args.batteries or "default", "--batteries", BATTERY_PRESETS)
        args.load_list = _floats(args.load or "1", "--load")
    except ValueError as exc:
        ap.error(str(exc))
    if args.smoke:  # one setting
        args.battery_list, args.load_list = args.battery_list[:1], args.load_list[:1]
    args.shape_list = [s for s in args.shapes.split(",") if s]
    args.depot_list = [int(x) for x in args.depots.split(",")]
    args.drone_list = [int(x) for x in args.drones.split(",")]
    args.alpha_list = [float(x) for x in args.alphas.split(",")]
    args.refs = [m for m in args.against.split(",") if m]
    return args


def make_tasks(args: argparse.Namespace, files: dict[tuple[str, float], Path]) -> list[tuple]:
    """One :func:`_job` per city, load, battery preset, setting and method, and, but for
    the grid, the α sweep's (16 areas, 8 drones) where the settings do not hold it."""
    methods = ("marops", *args.refs)
    tasks: list[tuple] = []
    for s in args.shape_list:
        for k in args.load_list:
            for bat in args.battery_list:
                city = (str(files[(s, k)]), s, args.history)
                rest = (args.policy, args.config, bat, k)
                for n in args.depot_list:
                    for u in args.drone_list:
                        tasks.extend((*city, n, u, 0.5, m, *rest) for m in methods)
                for a in [] if args.grid_run else args.alpha_list:
                    if a == 0.5 and 16 in args.depot_list and 8 in args.drone_list:
                        continue  # already in the settings above
                    tasks.extend((*city, 16, 8, a, m, *rest) for m in methods)
    return tasks


def replay_all(tasks: list[tuple], workers: int) -> list[dict[str, Any]]:
    """Every task's rows, in the tasks' order; a line on stderr as each job ends."""
    t0 = time.perf_counter()
    parts: dict[int, list[dict[str, Any]]] = {}
    with mp.get_context("spawn").Pool(workers) as pool:
        for i, part, seconds in pool.imap_unordered(_run, enumerate(tasks), chunksize=1):
            parts[i] = part
            _, s, _, n, u, a, m, _, _, bat, k = tasks[i]
            print(
                f"[{len(parts)}/{len(tasks)}] {s}, {n} areas, {u} drones, batteries {bat}, "
                f"load ×{k:g}, α {a:g}, {m}: {len(part)} days in {seconds:.0f} s",
                file=sys.stderr,
                flush=True,
            )
    rows = [r for i in range(len(tasks)) for r in parts[i]]
    print(f"{len(rows)} day replays in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return rows


def report_grid(args: argparse.Namespace, rows: list[dict[str, Any]]) -> None:
    """The generalisation benchmark's table, its JSON, the action mix per shape and the
    operating model per method."""
    refs = args.refs
    if len(refs) > 1:
        best = with_best(rows, refs)
    else:  # one reference is the day's best of one
        best = rows + [
            {**r, "method": BEST, "rule": r["method"]} for r in rows if r["method"] == refs[0]
        ]
    table = grid_table(best)
    if args.json:
        run = {
            "shapes": {s: SEEDS[s] for s in args.shape_list},
            "days": args.days,
            "history": args.history,
            "drones": args.drone_list,
            "depots": args.depot_list,
            "batteries": {b: BATTERY_PRESETS[b] for b in args.battery_list},
            "load": args.load_list,
            "against": refs,
            "policy": args.policy,
            "config": args.config,
        }
        doc = {"run": run, "settings": table, "rows": rows}
        Path(args.json).write_text(json.dumps(doc, indent=1))
    print_grid(table, refs, args.markdown)
    print_choices(rows, "marops", args.markdown)
    print_operations(rows, ("marops", *refs), args.markdown)


def main() -> None:
    args = parse_args()
    files = held_out_cities(args.shape_list, args.days, "marops-heldout-", tuple(args.load_list))
    rows = replay_all(make_tasks(args, files), args.workers)
    if args.grid_run:
        report_grid(args, rows)
        return
    refs = args.refs
    methods = ("marops", *refs)
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
