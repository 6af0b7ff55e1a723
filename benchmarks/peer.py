"""marops' window plans against PyVRP on the same states, judged by one objective.

Every plan is scored by the window objective (docs/method.md, "The window objective"):
J = Σ route energy + λ Σ_pending v_r (1 − served_r) and its controllable part
G = λ Σ_served v_r − Σ energy (higher is better), with PyVRP's routes re-costed by
marops' exact payload-aware energy model (their order improved for energy, landing
at the depot nearest the last customer).

* **Open loop.** The states a ``marops replay-day`` faces at each window (8 drones,
  16 depots, α 0.5) are given to: ``marops`` (route pool, the learned range's
  destination), ``marops:nearest`` (the pool landing nearest the last customer),
  ``paper`` (the paper's top-M̂ subsets) and PyVRP at 0.01 / 0.1 / 1 s. Per window and
  in total: J, G, served, energy, wall and CPU milliseconds.
* **Closed loop.** Each method flies its own plans for the whole day: delivered,
  average delay, energy.
* **Large window** (``--large``): 64 depots, 100 drones, 10,000 pending requests;
  marops on the whole window against PyVRP at 1 s on the 1,500 most delayed requests
  (and marops on the same prefilter).

Needs the ``bench`` extra (``pip install -e '.[bench]'``, which brings PyVRP).

    python benchmarks/peer.py [--seeds 101,202] [--days 11,12] [--large] [--quiet] [--smoke]

``--smoke``: one day, PyVRP at 0.01 s only, and the large window (CI runs it so the
script keeps up with the library; its figures mean nothing).
"""

from __future__ import annotations

import argparse
import datetime as dt
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).parent.resolve()]

import numpy as np  # noqa: E402

from marops_cli.config import PlannerConfig, override  # noqa: E402
from marops_cli.data.prepare import prepare_day  # noqa: E402
from marops_cli.data.synth import SynthConfig, generate, write  # noqa: E402
from marops_cli.energy import EnergyModel  # noqa: E402
from marops_cli.plans.objective import WindowScore, lam_j, score_routes  # noqa: E402
from marops_cli.plans.pool import finish_route  # noqa: E402
from marops_cli.plans.pyvrp_routes import solve_window  # noqa: E402
from marops_cli.plans.select import make_selector  # noqa: E402
from marops_cli.plans.window import DroneRoute, WindowPlan, plan_routes  # noqa: E402
from marops_cli.policies.base import Policy, WindowView, start_day  # noqa: E402
from marops_cli.sim.scenario import load_scenario, method_policy  # noqa: E402
from marops_cli.sim.state import DayState, default_fleet  # noqa: E402

PYVRP_S = (0.01, 0.1, 1.0)
Planner = Callable[[WindowView, np.ndarray], list[DroneRoute]]


def pyvrp_routes(
    view: WindowView, model: EnergyModel, lam: float, seconds: float, seed: int = 0
) -> list[DroneRoute]:
    """PyVRP's plan of the window as drone routes (exact energy, order improved)."""
    peer = solve_window(
        view.depots.xy,
        view.drone_depot,
        view.pending_xy,
        view.pending_weight,
        1.0 + view.pending_delay_h,
        lam,
        model,
        time_limit_s=seconds,
        seed=seed,
    )
    free = {u: int(s) for u, s in enumerate(view.drone_depot)}
    routes = []
    for s, stops in zip(peer.start, peer.stops, strict=True):
        u = next(u for u, d in free.items() if d == int(s))  # a drone of that start depot
        del free[u]
        xy, w = view.pending_xy[stops], view.pending_weight[stops]
        order, end = finish_route(view.depots.xy[s], None, view.depots.xy, xy, w, model)
        st = stops[order]
        pts = np.vstack([view.depots.xy[s], view.pending_xy[st], view.depots.xy[end]])
        legs_m, legs_j = model.route_energy(pts, view.pending_weight[st])
        routes.append(
            DroneRoute(
                u,
                int(s),
                end,
                0,
                tuple(int(view.pending_idx[i]) for i in st),
                legs_m,
                legs_j,
                float(w.sum()),
            )
        )
    for u, s in free.items():  # drones PyVRP left at their depot
        routes.append(DroneRoute(u, s, s, 0, (), np.zeros(1), np.zeros(1), 0.0))
    return sorted(routes, key=lambda r: r.drone)


def marops_routes(cfg: PlannerConfig, model: EnergyModel, scope: str = "range") -> Planner:
    selector = make_selector(cfg.plan)

    def plan(view: WindowView, actions: np.ndarray) -> list[DroneRoute]:
        return plan_routes(view, actions, model, cfg.plan, selector, scope=scope).routes

    return plan


def score(view: WindowView, routes: list[DroneRoute], lam: float) -> WindowScore:
    return score_routes(
        view.pending_idx, view.pending_delay_h, [(r.stops, r.energy_j) for r in routes], lam
    )


def check(routes: list[DroneRoute], model: EnergyModel) -> int:
    """Routes breaking payload or battery (none expected from either side)."""
    return sum(
        r.payload_kg > model.max_payload_kg + 1e-9 or r.energy_j > model.usable_j + 1e-6
        for r in routes
    )


def timed(fn: Callable[[], list[DroneRoute]]) -> tuple[list[DroneRoute], float, float]:
    w0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - w0, time.process_time() - c0


def planners(
    cfg: PlannerConfig,
    model: EnergyModel,
    lam: float,
    variants: dict[str, PlannerConfig],
    pyvrp_s: tuple[float, ...] = PYVRP_S,
) -> dict[str, Planner]:
    out: dict[str, Planner] = {
        "marops": marops_routes(cfg, model),
        "marops:nearest": marops_routes(override(cfg, plan__landing="nearest"), model),
        "paper": marops_routes(override(cfg, plan__planner="subsets"), model),
    }
    out.update({n: marops_routes(c, model) for n, c in variants.items()})
    for s in pyvrp_s:
        out[f"pyvrp {s:g}s"] = lambda v, a, s=s: pyvrp_routes(v, model, lam, s, seed=v.t)
    return out


def closed_loop(
    name: str,
    plan: Planner,
    policy: Policy,
    reqs,
    depots,
    fleet,
    cfg,
    model,  # noqa: ANN001
) -> dict[str, float]:
    state = DayState(reqs, depots, fleet, cfg.plan.coverage, cfg.plan.ties)
    start_day(policy, cfg, cfg.sim.seed)
    energy = 0.0
    for t in range(reqs.n_windows):
        view = state.view(t)
        routes = plan(view, policy.act(view))
        energy += sum(r.energy_j for r in routes)
        state.apply(WindowPlan(t, routes, None, 0), model.speed_ms)  # type: ignore[arg-type]
    delivered = state.delivered_w >= 0
    return {
        "delivered": int(delivered.sum()),
        "requests": len(reqs),
        "avg_delay_h": float(state.delivery_delay_h().mean()),
        "energy_kj": energy / 1e3,
    }


def run_day(
    data: Path,
    day: dt.date,
    cfg: PlannerConfig,
    quiet: bool,
    variants: dict[str, PlannerConfig],
    pyvrp_s: tuple[float, ...] = PYVRP_S,
) -> dict[str, dict]:
    """Open loop over the states of a marops replay, then every method's closed loop."""
    model = EnergyModel(cfg.energy)
    lam = lam_j(cfg.plan.alpha, model.usable_j)
    scn = load_scenario(data, cfg, replay_days=[day])
    reqs = prepare_day(scn.table, scn.frame, day, cfg.data)
    fleet = default_fleet(scn.depots, cfg.sim.drones)
    policy = method_policy("marops", None, cfg.sim.seed)
    start_day(policy, cfg, cfg.sim.seed)
    state = DayState(reqs, scn.depots, fleet, cfg.plan.coverage, cfg.plan.ties)
    methods = planners(cfg, model, lam, variants, pyvrp_s)
    rows: dict[str, dict[str, list[float]]] = {m: {} for m in methods}
    for t in range(reqs.n_windows):
        view = state.view(t)
        actions = policy.act(view)
        line = []
        own = None
        for name, plan in methods.items():
            routes, wall, cpu = timed(lambda p=plan, v=view, a=actions: p(v, a))
            sc = score(view, routes, lam)
            rec = rows[name]
            for k, x in (
                ("J", sc.J),
                ("G", sc.G),
                ("served", sc.served),
                ("energy", sc.energy_j),
                ("wall", wall),
                ("cpu", cpu),
                ("broken", check(routes, model)),
            ):
                rec.setdefault(k, []).append(float(x))
            line.append(f"{name} G {sc.G / 1e3:7.0f} s {sc.served:3d} {1e3 * cpu:6.1f}ms")
            if name == "marops":
                own = routes
        if not quiet:
            print(f"  w{t:02d} pending {view.pending_idx.size:4d} | " + " | ".join(line))
        state.apply(WindowPlan(t, own, None, 0), model.speed_ms)  # type: ignore[arg-type]
    closed = {}
    for name in ("marops", "marops:nearest", *variants, "paper", "pyvrp 0.01s"):
        c = variants.get(name, cfg)
        pol = method_policy("marops", None, c.sim.seed)
        closed[name] = closed_loop(name, methods[name], pol, reqs, scn.depots, fleet, c, model)
    return {"open": rows, "closed": closed}


def report(results: list[dict]) -> None:
    names = list(results[0]["open"])
    longest = [n for n in names if n.startswith("pyvrp")][-1]  # PyVRP's longest search
    print(
        f"\nopen loop, all windows: Σ J, Σ G (MJ), G / G({longest}), served, energy (MJ),"
        " CPU ms per window (median, max), wall ms (median), broken routes"
    )
    ref = sum(sum(r["open"][longest]["G"]) for r in results)
    for n in names:
        col = {k: [x for r in results for x in r["open"][n][k]] for k in results[0]["open"][n]}
        g = sum(col["G"])
        print(
            f"{n:>15} J {sum(col['J']) / 1e6:8.2f}  G {g / 1e6:7.2f}  ({g / ref:5.3f})"
            f"  served {int(sum(col['served'])):5d}  energy {sum(col['energy']) / 1e6:6.2f}"
            f"  cpu {1e3 * statistics.median(col['cpu']):7.1f} / {1e3 * max(col['cpu']):7.1f}"
            f"  wall {1e3 * statistics.median(col['wall']):7.1f}  broken {int(sum(col['broken']))}"
        )
    print(
        "\nclosed loop (each method flies its own plans): delivered / requests, "
        "average delay h, energy kJ"
    )
    for n in results[0]["closed"]:
        d = sum(r["closed"][n]["delivered"] for r in results)
        q = sum(r["closed"][n]["requests"] for r in results)
        delay = statistics.mean(r["closed"][n]["avg_delay_h"] for r in results)
        e = sum(r["closed"][n]["energy_kj"] for r in results)
        per = ", ".join(
            f"{r['closed'][n]['delivered']}/{r['closed'][n]['avg_delay_h']:.2f}h" for r in results
        )
        print(f"{n:>15} {d:5d}/{q:5d}  delay {delay:.3f} h  energy {e:9.0f} kJ   ({per})")


def paired(
    seeds: list[int], days: list[int], cfg: PlannerConfig, variants: dict[str, PlannerConfig]
) -> None:
    """Closed loop only, many days: each variant against PyVRP at 0.01 s, paired by day."""
    model = EnergyModel(cfg.energy)
    lam = lam_j(cfg.plan.alpha, model.usable_j)
    names = [*variants, "pyvrp 0.01s"]
    per: dict[str, list[dict[str, float]]] = {n: [] for n in names}
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds:
            data = Path(tmp) / f"synth{seed}.csv"
            write(generate(SynthConfig(days=max(days), seed=seed)), data)
            for d in days:
                day = dt.date(2022, 8, d)
                scn = load_scenario(data, cfg, replay_days=[day])
                reqs = prepare_day(scn.table, scn.frame, day, cfg.data)
                fleet = default_fleet(scn.depots, cfg.sim.drones)
                for n in names:
                    c = variants.get(n, cfg)
                    plan = (
                        marops_routes(c, model)
                        if n in variants
                        else lambda v, a: pyvrp_routes(v, model, lam, 0.01, seed=v.t)
                    )
                    pol = method_policy("marops", None, c.sim.seed)
                    per[n].append(closed_loop(n, plan, pol, reqs, scn.depots, fleet, c, model))
                print(
                    f"seed {seed} day {day}: "
                    + " | ".join(
                        f"{n} {per[n][-1]['delivered']}/{per[n][-1]['avg_delay_h']:.3f}h/"
                        f"{per[n][-1]['energy_kj']:.0f}kJ"
                        for n in names
                    ),
                    flush=True,
                )
    ref = per["pyvrp 0.01s"]
    print(f"\nclosed loop, {len(ref)} days, paired against pyvrp 0.01s (mean ± 95 % CI):")
    for n in names:
        rows = per[n]
        dlv = sum(r["delivered"] for r in rows)
        req = sum(r["requests"] for r in rows)
        line = f"{n:>22} delivered {dlv}/{req}"
        for k, unit in (("avg_delay_h", "h"), ("energy_kj", "kJ")):
            diff = np.array([r[k] - q[k] for r, q in zip(rows, ref, strict=True)])
            half = 1.96 * diff.std(ddof=1) / np.sqrt(diff.size) if diff.size > 1 else 0.0
            mean = statistics.mean(r[k] for r in rows)
            line += f"  {k} {mean:.3f} (Δ {diff.mean():+.4f} ± {half:.4f} {unit})"
        print(line)


def large(cfg: PlannerConfig, pyvrp_s: float = 1.0) -> None:
    """64 depots, 100 drones, 10,000 pending: marops whole and on PyVRP's prefilter."""
    sys.path.insert(0, str(Path(__file__).parent))
    from plan_window import large_view  # the same synthetic window as that benchmark

    cfg = override(cfg, plan__landing="nearest")
    model = EnergyModel(cfg.energy)
    lam = lam_j(cfg.plan.alpha, model.usable_j)
    view = large_view(cfg)
    actions = np.zeros(view.n_drones, dtype=np.int64)
    keep = np.lexsort((view.pending_due_s, -view.pending_delay_h))[:1500]
    pre = WindowView(
        t=view.t,
        n_windows=view.n_windows,
        window_h=view.window_h,
        depots=view.depots,
        ranges=view.ranges,
        drone_depot=view.drone_depot,
        pending_idx=view.pending_idx[keep],
        pending_xy=view.pending_xy[keep],
        pending_area=view.pending_area[keep],
        pending_delay_h=view.pending_delay_h[keep],
        pending_due_w=view.pending_due_w[keep],
        pending_due_s=view.pending_due_s[keep],
        pending_weight=view.pending_weight[keep],
    )
    print(
        f"\nlarge window: {len(view.depots)} depots, {view.n_drones} drones, "
        f"{view.pending_idx.size} pending; prefilter: the 1,500 most delayed"
    )
    for name, v, fn in (
        ("marops (all)", view, marops_routes(cfg, model)),
        ("marops:global (all)", view, marops_routes(cfg, model, "global")),
        ("marops (1,500)", pre, marops_routes(cfg, model)),
        (f"pyvrp {pyvrp_s:g}s (1,500)", pre, lambda v, a: pyvrp_routes(v, model, lam, pyvrp_s)),
    ):
        routes, wall, cpu = timed(lambda fn=fn, v=v: fn(v, actions))
        sc = score(view, routes, lam)  # judged on the whole window
        print(
            f"{name:>20} G {sc.G / 1e6:8.2f} MJ  served {sc.served:5d}  "
            f"wall {wall:6.2f} s  cpu {cpu:6.2f} s  broken {check(routes, model)}"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", default="101,202", help="marops synth seeds")
    ap.add_argument("--days", default="11,12", help="days of August to replay (history: 1..10)")
    ap.add_argument("--large", action="store_true", help="also the large window")
    ap.add_argument("--only-large", action="store_true")
    ap.add_argument("--quiet", action="store_true", help="totals only")
    ap.add_argument(
        "--variants",
        default="",
        metavar="SETTINGS",
        help="more marops variants: ';'-separated, each ','-separated [plan] settings, e.g. "
        "'landing=nearest,pool_urgency=0;pool_iterations=120'",
    )
    ap.add_argument(
        "--closed",
        action="store_true",
        help="closed loop only, every seed and day, each marops variant paired against "
        "PyVRP at 0.01 s (mean differences with 95 %% CIs)",
    )
    ap.add_argument("--smoke", action="store_true", help="1 day, PyVRP 0.01 s, large (CI)")
    args = ap.parse_args()
    pyvrp_s = PYVRP_S
    if args.smoke:
        args.seeds, args.days, args.quiet, args.large, pyvrp_s = "101", "11", True, True, (0.01,)
    cfg = PlannerConfig()
    variants = {}
    for v in filter(None, args.variants.split(";")):
        kv = dict(x.split("=", 1) for x in v.split(",") if x)
        variants[v] = override(cfg, **{f"plan__{k}": x for k, x in kv.items()})
    if args.closed:
        variants = {"marops": cfg, **variants}
        seeds = [int(s) for s in args.seeds.split(",")]
        days = [int(x) for x in args.days.split(",")]
        paired(seeds, days, cfg, variants)
        return
    if not args.only_large:
        results = []
        with tempfile.TemporaryDirectory() as tmp:
            for seed in (int(s) for s in args.seeds.split(",")):
                data = Path(tmp) / f"synth{seed}.csv"
                write(generate(SynthConfig(days=12, seed=seed)), data)
                for d in (int(x) for x in args.days.split(",")):
                    day = dt.date(2022, 8, d)
                    print(f"seed {seed}, day {day}:")
                    results.append(run_day(data, day, cfg, args.quiet, variants, pyvrp_s))
        report(results)
    if args.large or args.only_large:
        large(cfg, max(pyvrp_s))


if __name__ == "__main__":
    main()
