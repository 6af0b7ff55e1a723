"""marops' window plans against PyVRP on the same states, judged by one objective.

Every plan is scored by the window objective (docs/method.md, "The window objective"):
J = Σ route energy + λ Σ_pending v_r (1 − served_r) and its controllable part
G = λ Σ_served v_r − Σ energy (higher is better), with PyVRP's routes re-costed by
marops' exact payload-aware energy model (their order improved for energy, landing
at the depot nearest the last customer). Days come from ``marops synth`` (each city
shape and seed, 8 drones, 16 depots, α 0.5), or from LaDe exports (``--data``, each
file one city, segmented as ``marops segment`` would, its other days the history)
under the operating model of ``--config`` (default: the realistic model, parcels
waiting at their own depot; ``examples/paper.toml``: the paper's, every parcel at
every depot). Under ``stock = "home"`` PyVRP is told each
parcel's depot (a drone carries only its departure depot's parcels) and flies only the
drones that can fly the window. ``marops`` always runs the route pool, ``paper`` the
paper's subsets planner; the rest of the config is shared.

* **Open loop.** The states a ``marops replay-day`` faces at each window are given to:
  ``marops`` (route pool, the learned actor's landing), ``marops:nearest`` (the pool
  landing nearest the last customer), ``paper`` (the paper's top-M̂ subsets), any
  ``--variants`` and PyVRP at each ``--pyvrp-s`` limit (CPU seconds). Per window and in
  total: G, served, CPU ms; Σ G of marops over Σ G of PyVRP at each limit (all windows
  and per shape), the windows PyVRP wins, and marops' median CPU per window (each
  window planned ``--repeats`` times: the least CPU of them, and their median). Each
  window prints its backlog: parcels pending, already due, drones ready, and the load:
  the weight of the due parcels over the ready drones' payload, the full flights every
  drone that can fly would need for what is already due (one per window). A window is
  *backlogged* when its load is above 5 (2.5 hours of due work at half-hour windows);
  each shape's median load is printed. The states are marops' own, so where its landing
  actor moves drones, marops' window pays for flights that put PyVRP's drones in place
  for free: ``--pyvrp-dest`` also gives PyVRP marops' landings (``pyvrp@dest``: each
  drone lands at its action's destination, one PyVRP leaves idle still flies there
  empty), so that only the routing differs.
* **Closed loop.** Each method flies its own plans for the whole day (PyVRP at each
  ``--closed-pyvrp-s`` limit): delivered, average delay, energy per day, and the check
  against PyVRP at 0.1 s: delivered ≥, average delay ≤, energy ≤ 1.03×. Every day of
  ``--shapes`` × ``--seeds`` × ``--days`` flies the closed loop; the open loop only
  those of ``--open-seeds``.
* **Frontier** (``--frontier 0.2,0.3,0.5,0.7,0.8,0.9``): the closed loop of marops (and
  ``--variants``) and of PyVRP at each ``--closed-pyvrp-s`` limit at every α of the grid,
  on every day; each method's point per α pooled over the days (delivered, average delay,
  energy, J, CPU per window), how many PyVRP points some marops point of the grid
  dominates (delivered ≥, delay ≤, energy ≤), marops − PyVRP paired per day at each α
  (J and energy in %, delay, delivered; mean and 95 % t interval) and the energy per
  delivered parcel from the lowest α to the highest.
* **Large window** (``--large``): 64 depots, 100 drones, 10,000 pending requests, every
  parcel at every depot; marops on the whole window and on the 1,500 most delayed
  requests PyVRP is given, PyVRP at the limits of 1 s and more (else its longest), all
  judged on the whole window.
* **Bound** (``--bound``): an upper bound on G per window from ``marops_cli.plans.bound``
  (its search capped at ``--bound-labels`` labels a window) and the gaps
  (bound − G) / bound of every method and of the best plan found; a variant
  ``bound=true`` is marops flying the better of its pool's plan and the bound's.

Needs the ``bench`` extra (``pip install -e '.[bench]'``, which brings PyVRP).

    python benchmarks/peer.py [--config TOML] [--shapes hubs,corridor] [--seeds 101,202]
        [--days 11,12 | --data export.csv --days 0820,0821] [--open-seeds SEEDS]
        [--pyvrp-s 0.01,0.1,1,5] [--closed-pyvrp-s 0.01,0.1,1] [--repeats N]
        [--variants SETTINGS] [--bound] [--bound-labels N] [--pyvrp-dest] [--large | --only-large]
        [--closed] [--frontier ALPHAS] [--quiet] [--json PATH] [--smoke]

``--closed``: the closed loop only; ``--json``: every figure (per window, per day and
the totals) to a file. ``--smoke``: one day, PyVRP at 0.01 s only, and the large window
(CI runs it so the script keeps up with the library; its figures mean nothing).
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import statistics
import sys
import tempfile
import time
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).parent.resolve()]

import numpy as np  # noqa: E402
from pyvrp.exceptions import PenaltyBoundWarning  # noqa: E402

from marops_cli.config import OpsConfig, PlannerConfig, load_config, override  # noqa: E402
from marops_cli.data.dates import parse_days  # noqa: E402
from marops_cli.data.prepare import prepare_day  # noqa: E402
from marops_cli.data.synth import SynthConfig, generate, write  # noqa: E402
from marops_cli.data.table import DayRequests  # noqa: E402
from marops_cli.energy import EnergyModel  # noqa: E402
from marops_cli.plans.bound import window_bound  # noqa: E402
from marops_cli.plans.kernels import kernels_now  # noqa: E402
from marops_cli.plans.objective import lam_j, relative_gap  # noqa: E402
from marops_cli.plans.pool import finish_route  # noqa: E402
from marops_cli.plans.problem import DroneTask, WindowProblem  # noqa: E402
from marops_cli.plans.pyvrp_routes import solve_window  # noqa: E402
from marops_cli.plans.view import EVERY_DEPOT, FREE  # noqa: E402
from marops_cli.plans.window import DroneRoute, WindowPlan, score_plan  # noqa: E402
from marops_cli.policies.base import WindowView, start_day  # noqa: E402
from marops_cli.segment.depots import Depots  # noqa: E402
from marops_cli.sim.scenario import load_scenario, method_policy  # noqa: E402
from marops_cli.sim.state import DayState, default_fleet  # noqa: E402
from marops_cli.sim.step import WindowStep, plan_step  # noqa: E402

PYVRP_S = (0.01, 0.1, 1.0, 5.0)
CLOSED_S = (0.01, 0.1, 1.0)
REF_S = 0.1  # the closed loop's check is against PyVRP at this limit
ENERGY_TOL = 1.03  # the closed loop's check: marops' energy at most this times PyVRP's
PREFILTER = 1500  # the large window's requests given to PyVRP
BACKLOG_LOAD = 5.0  # a window whose load (backlog) is above this is backlogged
Planner = Callable[[WindowView, np.ndarray], list[DroneRoute]]
Bound = Callable[[WindowView, np.ndarray], dict[str, float]]


def pyvrp_name(seconds: float) -> str:
    return f"pyvrp {seconds:g}s"


def dest_name(seconds: float) -> str:
    """PyVRP at ``seconds`` flying marops' landings (``--pyvrp-dest``)."""
    return f"pyvrp@dest {seconds:g}s"


# --- the planners -------------------------------------------------------------------


def pyvrp_routes(
    view: WindowView,
    model: EnergyModel,
    lam: float,
    seconds: float,
    seed: int = 0,
    actions: np.ndarray | None = None,
) -> list[DroneRoute]:
    """PyVRP's plan of the window as drone routes (exact energy, order improved).

    Only the drones that can fly are vehicles; under home stock each carries only its
    departure depot's parcels (its task's allowed requests: exact, as a parcel can go
    only with a drone from its depot), and a drone whose depot holds none stays. Each
    lands at the depot nearest its last stop; with marops' ``actions``
    (``--pyvrp-dest``) each lands where its action says instead (the free landing:
    nearest its last stop), and one PyVRP leaves idle flies there empty, as marops'
    plan does, so that only the routing differs from marops'."""
    end = np.full(view.n_drones, -1, dtype=np.int64)
    if actions is not None:
        from marops_cli.plans.problem import flown_actions

        acts = flown_actions(view, actions, [model] * view.n_drones, "range")
        for u, (s, a) in enumerate(zip(view.drone_depot, acts, strict=True)):
            if a != FREE and view.ready(u):
                end[u] = int(view.depots.candidates[int(s), int(a)])
    fly = np.array([u for u in range(view.n_drones) if view.ready(u)], dtype=np.int64)
    allowed = None
    if not (view.pending_stock == EVERY_DEPOT).all() and fly.size:
        allowed = view.pending_stock[None, :] == view.drone_depot[fly, None]
        keep = allowed.any(axis=1)
        fly, allowed = fly[keep], allowed[keep]
    routes = []
    if fly.size and view.pending_idx.size:
        every = np.arange(view.pending_idx.size, dtype=np.int64)
        serves = [every] * fly.size if allowed is None else [every[ok] for ok in allowed]
        tasks = [
            DroneTask(int(view.drone_depot[u]), int(end[u]), own, model)
            for u, own in zip(fly, serves, strict=True)
        ]
        problem = WindowProblem.of_requests(
            view.depots.xy, view.pending_xy, view.pending_weight, view.pending_delay_h, lam, tasks
        )
        peer = solve_window(problem, time_limit_s=seconds, seed=seed)
        free = {int(u): (int(view.drone_depot[u]), int(end[u])) for u in fly}
        for s, e, stops in zip(peer.start, peer.end, peer.stops, strict=True):
            # A drone of that start and end (a free landing: where some end is fixed,
            # PyVRP brings it back to its start).
            u = next(
                u
                for u, (us, ue) in free.items()
                if us == int(s) and (ue == int(e) or (ue < 0 and int(e) in (-1, us)))
            )
            del free[u]
            routes.append(
                peer_route(view, model, u, int(s), stops, None if end[u] < 0 else int(end[u]))
            )
    flying = {r.drone for r in routes}
    for u, s in enumerate(view.drone_depot):
        if u in flying:
            continue
        if end[u] < 0 or end[u] == s:
            routes.append(stay(u, int(s)))
        else:  # marops' landing, flown empty
            pts = view.depots.xy[[int(s), int(end[u])]]
            legs_m, legs_j = model.route_energy(pts, np.zeros(0))
            routes.append(DroneRoute(u, int(s), int(end[u]), 0, (), legs_m, legs_j, 0.0))
    return sorted(routes, key=lambda r: r.drone)


def peer_route(
    view: WindowView,
    model: EnergyModel,
    u: int,
    s: int,
    stops: np.ndarray,
    end_at: int | None = None,
) -> DroneRoute:
    """PyVRP's stops for drone ``u`` from depot ``s``, in the energy-best order, landing
    at the depot nearest the last customer (or at ``end_at``), costed exactly."""
    xy, w = view.pending_xy[stops], view.pending_weight[stops]
    end_xy = None if end_at is None else view.depots.xy[end_at]
    order, end = finish_route(view.depots.xy[s], end_xy, view.depots.xy, xy, w, model)
    end = end if end_at is None else end_at
    st = stops[order]
    pts = np.vstack([view.depots.xy[s], view.pending_xy[st], view.depots.xy[end]])
    legs_m, legs_j = model.route_energy(pts, view.pending_weight[st])
    idx = tuple(int(view.pending_idx[i]) for i in st)
    return DroneRoute(u, s, end, 0, idx, legs_m, legs_j, float(w.sum()))


def stay(u: int, s: int) -> DroneRoute:
    return DroneRoute(u, s, s, 0, (), np.zeros(1), np.zeros(1), 0.0)


def marops_planner(
    cfg: PlannerConfig,
    planner: str = "pool",
    scope: Literal["range", "global"] = "range",
    **plan: object,
) -> Planner:
    """marops' window step under ``cfg`` (as replay flies it) with ``planner`` and
    ``plan`` settings overridden."""
    how = WindowStep.make(
        override(cfg, **{f"plan__{k}": v for k, v in plan.items()}),
        scope=scope,
        planner=planner,
    )
    return lambda view, actions: plan_step(view, actions, how).routes


@dataclass(frozen=True)
class Setup:
    """What every day of a run shares."""

    cfg: PlannerConfig
    pyvrp_s: tuple[float, ...]
    closed_s: tuple[float, ...]
    variants: dict[str, dict[str, str]]
    repeats: int = 1
    bound: Bound | None = None
    dest: bool = False
    """Also PyVRP flying marops' own landings (``--pyvrp-dest``), in the open loop."""

    @property
    def model(self) -> EnergyModel:
        return EnergyModel(self.cfg.energy)

    @property
    def lam(self) -> float:
        return lam_j(self.cfg.plan.alpha, self.model.usable_j)

    @property
    def ref(self) -> str:
        """The PyVRP run the closed loop is checked against."""
        return pyvrp_name(REF_S if REF_S in self.closed_s else min(self.closed_s))

    def planners(self, closed: bool = False) -> dict[str, Planner]:
        """Every method by name, PyVRP at the open loop's limits or (``closed``) the
        closed loop's."""
        model, lam, cfg = self.model, self.lam, self.cfg
        out: dict[str, Planner] = {
            "marops": marops_planner(cfg),
            "marops:nearest": marops_planner(cfg, landing="nearest"),
            "paper": marops_planner(cfg, "subsets"),
        }
        out.update({n: marops_planner(cfg, **kv) for n, kv in self.variants.items()})
        for s in self.closed_s if closed else self.pyvrp_s:
            out[pyvrp_name(s)] = lambda v, a, s=s: pyvrp_routes(v, model, lam, s, seed=v.t)
        if self.dest and not closed:
            for s in self.pyvrp_s:
                out[dest_name(s)] = lambda v, a, s=s: pyvrp_routes(
                    v, model, lam, s, seed=v.t, actions=a
                )
        return out


def load_bound(cfg: PlannerConfig) -> Bound:
    """The window bound of ``marops_cli.plans.bound``.

    The relaxed bound: every drone that can fly lands freely and serves whatever its
    depot stocks, so it bounds every method's plan, PyVRP's included."""
    model = EnergyModel(cfg.energy)

    def bound(view: WindowView, actions: np.ndarray) -> dict[str, float]:
        res = window_bound(view, actions, model, cfg.plan, relaxed=True)
        return {"bound": res.bound, "converged": res.converged, "cpu_s": res.cpu_s}

    return bound


# --- scoring ------------------------------------------------------------------------


def check(view: WindowView, routes: list[DroneRoute], model: EnergyModel) -> int:
    """Routes breaking payload, battery or the stock rule (none expected from either side)."""
    stock = None
    if not (view.pending_stock == EVERY_DEPOT).all():
        stock = dict(zip(view.pending_idx.tolist(), view.pending_stock.tolist(), strict=True))
    return sum(
        r.payload_kg > model.max_payload_kg + 1e-9
        or r.energy_j > model.usable_j + 1e-6
        or (stock is not None and any(stock[i] != r.start for i in r.stops))
        for r in routes
    )


def timed(fn: Callable[[], list[DroneRoute]]) -> tuple[list[DroneRoute], float, float]:
    w0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - w0, time.process_time() - c0


def backlog(view: WindowView, model: EnergyModel) -> dict[str, float]:
    """Pending and due parcels, drones ready and the load: the due parcels' weight over
    the ready drones' payload (at least one drone)."""
    due = view.pending_due_w <= view.t
    ready = sum(view.ready(u) for u in range(view.n_drones))
    load = float(view.pending_weight[due].sum()) / (max(ready, 1) * model.max_payload_kg)
    return {
        "pending": int(view.pending_idx.size),
        "due": int(due.sum()),
        "ready": int(ready),
        "load": load,
    }


# --- days -----------------------------------------------------------------------------


@dataclass
class Day:
    """One replayed day of one city (a ``marops synth`` one, or an export's)."""

    shape: str
    seed: int
    date: dt.date
    reqs: DayRequests
    depots: Depots
    fleet: np.ndarray

    @property
    def label(self) -> str:
        return f"{self.shape} {self.seed} {self.date:%m-%d}"

    def key(self) -> dict[str, object]:
        return {"shape": self.shape, "seed": self.seed, "day": self.date.isoformat()}

    def state(self, cfg: PlannerConfig) -> DayState:
        p = cfg.plan
        model = EnergyModel.of(cfg.energy)
        return DayState(
            self.reqs, self.depots, self.fleet, p.coverage, p.ties, ops=cfg.ops, model=model
        )


def replay_days(
    cfg: PlannerConfig, shapes: list[str], seeds: list[int], dates: list[int], tmp: Path
) -> Iterator[Day]:
    """Every (shape, seed, day of August) in that order; history: the file's other days."""
    for shape in shapes:
        for seed in seeds:
            data = tmp / f"{shape}{seed}.csv"
            write(generate(SynthConfig(days=max(12, *dates), seed=seed, shape=shape)), data)  # type: ignore[arg-type]
            for d in dates:
                yield file_day(cfg, data, dt.date(2022, 8, d), shape, seed)


def file_day(cfg: PlannerConfig, data: Path, date: dt.date, shape: str, seed: int) -> Day:
    """One day of a LaDe export (segmented as ``marops segment`` would, the file's other
    days the history), labelled ``shape`` and ``seed``."""
    scn = load_scenario(data, cfg, replay_days=[date])
    reqs = prepare_day(scn.table, scn.frame, date, cfg.data)
    fleet = default_fleet(scn.depots, cfg.sim.drones)
    return Day(shape, seed, date, reqs, scn.depots, fleet)


def data_days(cfg: PlannerConfig, files: list[Path], dates: list[dt.date]) -> Iterator[Day]:
    """Every (export, date) in that order, each export labelled by its file name."""
    for path in files:
        for date in dates:
            yield file_day(cfg, path, date, path.stem, 0)


# --- open and closed loop -------------------------------------------------------------


def run_window(
    view: WindowView, actions: np.ndarray, name: str, plan: Planner, setup: Setup
) -> tuple[list[DroneRoute], dict[str, float]]:
    """One method's plan of one window and its figures (marops: ``repeats`` times)."""
    runs = [
        timed(lambda: plan(view, actions)) for _ in range(setup.repeats if name == "marops" else 1)
    ]
    routes, wall, _ = runs[0]
    cpus = [c for _, _, c in runs]
    sc = score_plan(view, routes, setup.lam)
    rec = {
        "G": sc.G,
        "J": sc.J,
        "served": sc.served,
        "energy_j": sc.energy_j,
        "cpu_s": min(cpus),
        "cpu_median_s": statistics.median(cpus),
        "wall_s": wall,
        "broken": check(view, routes, setup.model),
    }
    return routes, rec


def open_loop(day: Day, setup: Setup, quiet: bool) -> list[dict]:
    """Every method on the states of a marops replay of ``day``, window by window."""
    cfg, model = setup.cfg, setup.model
    policy = method_policy("marops", None, cfg.sim.seed, ops=cfg.ops)
    start_day(policy, cfg, cfg.sim.seed)
    state = day.state(cfg)
    methods = setup.planners()
    rows = []
    for t in range(day.reqs.n_windows):
        view = state.view(t)
        actions = policy.act(view)
        row: dict = {**day.key(), "t": t, **backlog(view, model), "methods": {}}
        own: list[DroneRoute] = []
        for name, plan in methods.items():
            routes, row["methods"][name] = run_window(view, actions, name, plan, setup)
            own = routes if name == "marops" else own
        row["bound"] = None if setup.bound is None else setup.bound(view, actions)
        rows.append(row)
        if not quiet:
            print(window_line(day, row), flush=True)
        state.apply(WindowPlan(t, own, None, 0), model.speed_ms)  # type: ignore[arg-type]
    return rows


def window_line(day: Day, row: dict) -> str:
    head = (
        f"  {day.label} w{row['t']:02d} pend {row['pending']:3d} due {row['due']:3d} "
        f"ready {row['ready']} load {row['load']:4.2f}"
    )
    cols = [
        f"{n} G {m['G'] / 1e3:6.0f}k s {m['served']:3d} {1e3 * m['cpu_s']:5.0f}ms"
        for n, m in row["methods"].items()
    ]
    if row["bound"] is not None:
        cols.append(f"bound {row['bound']['bound'] / 1e3:6.0f}k")
    return head + " | " + " | ".join(cols)


def closed_loop(day: Day, plan: Planner, setup: Setup) -> dict[str, float]:
    """``plan`` flies the whole day (its own states): delivered, delay, energy."""
    cfg, model = setup.cfg, setup.model
    policy = method_policy("marops", None, cfg.sim.seed, ops=cfg.ops)
    start_day(policy, cfg, cfg.sim.seed)
    state = day.state(cfg)
    energy = objective = cpu = 0.0
    for t in range(day.reqs.n_windows):
        view = state.view(t)
        c0 = time.process_time()
        routes = plan(view, policy.act(view))
        cpu += time.process_time() - c0
        energy += sum(r.energy_j for r in routes)
        objective += score_plan(view, routes, setup.lam).J
        state.apply(WindowPlan(t, routes, None, 0), model.speed_ms)  # type: ignore[arg-type]
    return {
        "delivered": int((state.delivered_w >= 0).sum()),
        "requests": int(state.delivered_w.size),
        "avg_delay_h": float(state.delivery_delay_h().mean()),
        "energy_kj": energy / 1e3,
        "objective_j_mj": objective / 1e6,
        "cpu_per_window_s": cpu / max(day.reqs.n_windows, 1),
    }


def closed_day(day: Day, setup: Setup) -> dict:
    """Every method's closed loop of ``day`` and the check against the reference."""
    runs = {n: closed_loop(day, p, setup) for n, p in setup.planners(closed=True).items()}
    m, ref = runs["marops"], runs[setup.ref]
    ok = {
        "delivered": m["delivered"] >= ref["delivered"],
        "delay": m["avg_delay_h"] <= ref["avg_delay_h"] + 1e-12,
        "energy": m["energy_kj"] <= ENERGY_TOL * ref["energy_kj"],
    }
    return {**day.key(), "methods": runs, "check": ok}


# --- the frontier over α ----------------------------------------------------------------


def frontier_day(day: Day, setup: Setup, alphas: list[float]) -> list[dict]:
    """marops (and ``--variants``) and PyVRP at each closed-loop limit fly ``day`` whole at
    every α: one row per (α, method)."""
    rows = []
    for a in alphas:
        at = replace(setup, cfg=override(setup.cfg, plan__alpha=a))
        model, lam, cfg = at.model, at.lam, at.cfg
        methods: dict[str, Planner] = {"marops": marops_planner(cfg)}
        methods.update({n: marops_planner(cfg, **kv) for n, kv in at.variants.items()})
        for sec in at.closed_s:
            methods[pyvrp_name(sec)] = lambda v, _, sec=sec, m=model, lam=lam: pyvrp_routes(
                v, m, lam, sec, seed=v.t
            )
        for name, plan in methods.items():
            rows.append({**day.key(), "alpha": a, "method": name, **closed_loop(day, plan, at)})
    return rows


def _mean_ci(x: np.ndarray) -> tuple[float, float, float]:
    """Mean and its 95 % t interval over days."""
    from scipy import stats

    x = np.asarray(x, dtype=np.float64)
    if x.size < 2:
        return float(x.mean()), float("nan"), float("nan")
    half = float(stats.t.ppf(0.975, x.size - 1) * x.std(ddof=1) / np.sqrt(x.size))
    return float(x.mean()), float(x.mean() - half), float(x.mean() + half)


def frontier_summary(rows: list[dict]) -> dict:
    """Points per (method, α) pooled over the days; every PyVRP point dominated by some
    marops point (of any α) or not; marops − PyVRP paired per day at each α; energy per
    parcel delivered from the lowest α to the highest."""
    alphas = sorted({r["alpha"] for r in rows})
    methods = list(dict.fromkeys(r["method"] for r in rows))
    points: dict[tuple[str, float], dict] = {}
    for m in methods:
        for a in alphas:
            mine = [r for r in rows if r["method"] == m and r["alpha"] == a]
            n_req = sum(r["requests"] for r in mine)
            points[(m, a)] = {
                "delivered": sum(r["delivered"] for r in mine),
                "requests": n_req,
                "avg_delay_h": sum(r["avg_delay_h"] * r["requests"] for r in mine) / max(n_req, 1),
                "energy_kj": sum(r["energy_kj"] for r in mine),
                "objective_j_mj": sum(r["objective_j_mj"] for r in mine),
                "cpu_per_window_s": statistics.mean(r["cpu_per_window_s"] for r in mine),
            }
    ours = [m for m in methods if not m.startswith("pyvrp")]
    peers = [m for m in methods if m.startswith("pyvrp")]

    def dominator(p: dict, of: str) -> float | None:
        for a in alphas:
            q = points[(of, a)]
            if (
                q["delivered"] >= p["delivered"]
                and q["avg_delay_h"] <= p["avg_delay_h"]
                and q["energy_kj"] <= p["energy_kj"]
            ):
                return a
        return None

    dominance = {
        m: {peer: {str(a): dominator(points[(peer, a)], m) for a in alphas} for peer in peers}
        for m in ours
    }
    paired: dict = {}
    key = ("shape", "seed", "day")
    for m in ours:
        for peer in peers:
            for a in alphas:
                mine = {
                    tuple(r[k] for k in key): r
                    for r in rows
                    if r["method"] == m and r["alpha"] == a
                }
                ref = {
                    tuple(r[k] for k in key): r
                    for r in rows
                    if r["method"] == peer and r["alpha"] == a
                }
                days = [d for d in mine if d in ref]
                dj = np.array(
                    [100 * (mine[d]["objective_j_mj"] / ref[d]["objective_j_mj"] - 1) for d in days]
                )
                de = np.array(
                    [100 * (mine[d]["energy_kj"] / ref[d]["energy_kj"] - 1) for d in days]
                )
                dd = np.array([mine[d]["avg_delay_h"] - ref[d]["avg_delay_h"] for d in days])
                dv = np.array(
                    [mine[d]["delivered"] - ref[d]["delivered"] for d in days], dtype=float
                )
                paired[f"{m} - {peer} @ {a:g}"] = {
                    "days": len(days),
                    "d_objective_pct": _mean_ci(dj),
                    "d_energy_pct": _mean_ci(de),
                    "d_delay_h": _mean_ci(dd),
                    "d_delivered_per_day": _mean_ci(dv),
                    "d_delivered_total": int(dv.sum()),
                    "days_j_better": int((dj <= 0).sum()),
                }
    per_parcel = {
        m: {a: points[(m, a)]["energy_kj"] / max(points[(m, a)]["delivered"], 1) for a in alphas}
        for m in methods
    }
    return {
        "alphas": alphas,
        "points": {f"{m} @ {a:g}": p for (m, a), p in points.items()},
        "dominance": dominance,
        "paired": paired,
        "energy_per_parcel_kj": {
            m: {f"{a:g}": v for a, v in d.items()} for m, d in per_parcel.items()
        },
        "per_parcel_drop_pct": {
            m: 100 * (1 - d[alphas[-1]] / d[alphas[0]]) for m, d in per_parcel.items()
        },
    }


def print_frontier(summary: dict) -> None:
    alphas = summary["alphas"]
    print(
        "\nfrontier over α (closed loop, pooled over the days): delivered/requests, "
        "average delay h, energy MJ, kJ per parcel, J MJ, CPU ms per window"
    )
    for name, p in summary["points"].items():
        print(
            f"  {name:>18}  {p['delivered']:5d}/{p['requests']:5d}  {p['avg_delay_h']:.3f} h"
            f"  {p['energy_kj'] / 1e3:7.1f} MJ  {p['energy_kj'] / max(p['delivered'], 1):5.1f}"
            f"  J {p['objective_j_mj']:8.1f}  {1e3 * p['cpu_per_window_s']:6.0f} ms"
        )
    for m, by_peer in summary["dominance"].items():
        for peer, at in by_peer.items():
            n = sum(v is not None for v in at.values())
            where = ", ".join(
                f"{a}: {'by ' + format(v, 'g') if v is not None else 'no'}" for a, v in at.items()
            )
            print(f"{peer} points dominated by a {m} point: {n} of {len(at)} ({where})")
    print("paired per day (mean [95 % CI]):")
    for name, d in summary["paired"].items():
        j, e, t, v = (
            d[k] for k in ("d_objective_pct", "d_energy_pct", "d_delay_h", "d_delivered_per_day")
        )
        print(
            f"  {name:>28} ({d['days']} days)  J {j[0]:+.1f} % [{j[1]:+.1f}, {j[2]:+.1f}]"
            f" ({d['days_j_better']}/{d['days']} days no worse)  energy {e[0]:+.1f} %"
            f" [{e[1]:+.1f}, {e[2]:+.1f}]  delay {t[0]:+.3f} h  delivered {v[0]:+.1f}/day"
            f" (total {d['d_delivered_total']:+d})"
        )
    for m, drop in summary["per_parcel_drop_pct"].items():
        print(f"{m}: energy per parcel from α {alphas[0]:g} to {alphas[-1]:g}: {-drop:+.1f} %")


# --- summaries ------------------------------------------------------------------------


def gap(bound: float, g: float) -> float:
    return relative_gap(bound, g) if bound > 0 else 0.0


def open_summary(rows: list[dict], setup: Setup) -> dict:
    """Totals per method, marops against PyVRP at each limit, CPU, backlog, bound."""
    names = list(rows[0]["methods"])
    shapes = sorted({r["shape"] for r in rows})

    def total(name: str, key: str, shape: str | None = None) -> float:
        return sum(r["methods"][name][key] for r in rows if shape in (None, r["shape"]))

    methods = {
        n: {
            "G": total(n, "G"),
            "J": total(n, "J"),
            "served": total(n, "served"),
            "energy_j": total(n, "energy_j"),
            "cpu_median_s": statistics.median(r["methods"][n]["cpu_s"] for r in rows),
            "cpu_max_s": max(r["methods"][n]["cpu_s"] for r in rows),
            "wall_median_s": statistics.median(r["methods"][n]["wall_s"] for r in rows),
            "broken": total(n, "broken"),
        }
        for n in names
    }
    versus = {}
    peers = [pyvrp_name(s) for s in setup.pyvrp_s]
    peers += [dest_name(s) for s in setup.pyvrp_s] if setup.dest else []
    for p in peers:
        versus[p] = {
            "ratio": total("marops", "G") / total(p, "G"),
            "per_shape": {sh: total("marops", "G", sh) / total(p, "G", sh) for sh in shapes},
            "pyvrp_wins": sum(r["methods"][p]["G"] > r["methods"]["marops"]["G"] for r in rows),
        }
    out = {
        "windows": len(rows),
        "shapes": shapes,
        "backlog": {
            sh: {
                "windows": sum(r["shape"] == sh for r in rows),
                "backlogged": sum(r["load"] > BACKLOG_LOAD for r in rows if r["shape"] == sh),
                "median_load": statistics.median(r["load"] for r in rows if r["shape"] == sh),
            }
            for sh in shapes
        },
        "methods": methods,
        "versus": versus,
        "marops_cpu_ms": {
            "repeats": setup.repeats,
            "median_of_min": 1e3 * statistics.median(r["methods"]["marops"]["cpu_s"] for r in rows),
            "median_of_median": 1e3
            * statistics.median(r["methods"]["marops"]["cpu_median_s"] for r in rows),
        },
    }
    if rows[0]["bound"] is not None:
        out["bound"] = bound_summary(rows)
    return out


def bound_summary(rows: list[dict]) -> dict:
    """The gaps to the bound: marops' and the best plan's, and bounds below a found G."""
    best = [max(m["G"] for m in r["methods"].values()) for r in rows]
    bounds = [r["bound"]["bound"] for r in rows]
    marops = [r["methods"]["marops"]["G"] for r in rows]
    return {
        "median_gap_marops": statistics.median(map(gap, bounds, marops)),
        "median_gap": {
            n: statistics.median(
                gap(b, r["methods"][n]["G"]) for b, r in zip(bounds, rows, strict=True)
            )
            for n in rows[0]["methods"]
        },
        "median_gap_best": statistics.median(map(gap, bounds, best)),
        "below_best": sum(b < g - 1e-6 * abs(g) for b, g in zip(bounds, best, strict=True)),
        "converged": sum(bool(r["bound"]["converged"]) for r in rows),
        "cpu_median_s": statistics.median(r["bound"]["cpu_s"] for r in rows),
    }


def print_open(summary: dict) -> None:
    print(
        f"\nopen loop, {summary['windows']} windows; backlogged (load > {BACKLOG_LOAD:g}) / "
        "windows, median load: "
        + ", ".join(
            f"{sh} {b['backlogged']}/{b['windows']}, {b['median_load']:.2f}"
            for sh, b in summary["backlog"].items()
        )
    )
    print("Σ J, Σ G (MJ), served, energy (MJ), CPU ms per window (median, max), wall ms, broken")
    for n, m in summary["methods"].items():
        print(
            f"{n:>15} J {m['J'] / 1e6:8.2f}  G {m['G'] / 1e6:7.2f}  served {int(m['served']):5d}"
            f"  energy {m['energy_j'] / 1e6:6.2f}  cpu {1e3 * m['cpu_median_s']:7.1f} /"
            f" {1e3 * m['cpu_max_s']:7.1f}  wall {1e3 * m['wall_median_s']:7.1f}"
            f"  broken {int(m['broken'])}"
        )
    print("\nΣ G marops / Σ G PyVRP (all windows; per shape), windows PyVRP wins")
    for p, v in summary["versus"].items():
        per = ", ".join(f"{sh} {x:.3f}" for sh, x in v["per_shape"].items())
        print(
            f"{p:>15} {v['ratio']:.3f}  ({per})  PyVRP better on {v['pyvrp_wins']}"
            f" of {summary['windows']}"
        )
    c = summary["marops_cpu_ms"]
    print(
        f"marops CPU per window: median {c['median_of_min']:.1f} ms (min of {c['repeats']}"
        f" per window), {c['median_of_median']:.1f} ms (median of them)"
    )
    if "bound" in summary:
        b = summary["bound"]
        print(
            f"bound: median gap (bound − G) / bound marops {100 * b['median_gap_marops']:.2f} %,"
            f" best plan {100 * b['median_gap_best']:.2f} %; bound below a found G on"
            f" {b['below_best']} windows; converged on {b['converged']};"
            f" CPU {1e3 * b['cpu_median_s']:.0f} ms median"
        )
        print(
            "median gap per method: "
            + ", ".join(f"{n} {100 * x:.2f} %" for n, x in b["median_gap"].items())
        )


def closed_summary(days: list[dict], ref: str) -> dict:
    """Totals per method, paired differences against ``ref`` (mean ± 95 % CI per day)."""
    names = list(days[0]["methods"])
    out: dict = {"ref": ref, "days": len(days), "methods": {}}
    for n in names:
        rows = [d["methods"][n] for d in days]
        refs = [d["methods"][ref] for d in days]
        m = {
            "delivered": sum(r["delivered"] for r in rows),
            "requests": sum(r["requests"] for r in rows),
            "avg_delay_h": statistics.mean(r["avg_delay_h"] for r in rows),
            "energy_kj": sum(r["energy_kj"] for r in rows),
        }
        for k in ("avg_delay_h", "energy_kj"):
            diff = np.array([r[k] - q[k] for r, q in zip(rows, refs, strict=True)])
            half = 1.96 * diff.std(ddof=1) / np.sqrt(diff.size) if diff.size > 1 else 0.0
            m[f"d_{k}"] = [float(diff.mean()), float(half)]
        out["methods"][n] = m
    out["passed_days"] = sum(all(d["check"].values()) for d in days)
    return out


def print_closed(days: list[dict], summary: dict) -> None:
    ref = summary["ref"]
    print(
        f"\nclosed loop (each method flies its own plans), per day: delivered/requests, "
        f"average delay h, energy MJ; check against {ref}: delivered ≥, delay ≤, "
        f"energy ≤ {ENERGY_TOL}×"
    )
    for d in days:
        cols = " | ".join(
            f"{n} {r['delivered']}/{r['requests']} {r['avg_delay_h']:.3f}h "
            f"{r['energy_kj'] / 1e3:.1f}MJ"
            for n, r in d["methods"].items()
        )
        ok = " ".join(f"{k} {'ok' if v else 'FAIL'}" for k, v in d["check"].items())
        print(f"  {d['shape']} {d['seed']} {d['day'][5:]}: {cols}  [{ok}]")
    print(f"totals over {summary['days']} days (Δ against {ref}: mean ± 95 % CI per day)")
    for n, m in summary["methods"].items():
        print(
            f"{n:>15} {m['delivered']:5d}/{m['requests']:5d}  delay {m['avg_delay_h']:.3f} h"
            f" (Δ {m['d_avg_delay_h'][0]:+.4f} ± {m['d_avg_delay_h'][1]:.4f})"
            f"  energy {m['energy_kj'] / 1e3:8.1f} MJ"
            f" (Δ {m['d_energy_kj'][0]:+.0f} ± {m['d_energy_kj'][1]:.0f} kJ,"
            f" {m['energy_kj'] / max(m['delivered'], 1):.1f} kJ per parcel delivered)"
        )
    print(f"check passed on {summary['passed_days']} of {summary['days']} days")


# --- the large window -----------------------------------------------------------------


def prefiltered(view: WindowView, n: int) -> WindowView:
    """``view`` with only its ``n`` most delayed requests (earliest due first among ties)."""
    keep = np.lexsort((view.pending_due_s, -view.pending_delay_h))[:n]
    return replace(
        view,
        pending_idx=view.pending_idx[keep],
        pending_xy=view.pending_xy[keep],
        pending_area=view.pending_area[keep],
        pending_delay_h=view.pending_delay_h[keep],
        pending_due_w=view.pending_due_w[keep],
        pending_due_s=view.pending_due_s[keep],
        pending_weight=view.pending_weight[keep],
        pending_stock=view.pending_stock[keep],
        pending_visible_w=None if view.pending_visible_w is None else view.pending_visible_w[keep],
        pending_servable=None if view.pending_servable is None else view.pending_servable[keep],
    )


def large(setup: Setup) -> list[dict]:
    """64 depots, 100 drones, 10,000 pending, every parcel at every depot: marops on the
    whole window and on PyVRP's prefilter, PyVRP at the limits of 1 s and more."""
    sys.path.insert(0, str(Path(__file__).parent))
    from plan_window import large_view  # the same synthetic window as that benchmark

    cfg = setup.cfg.model_copy(update={"ops": OpsConfig.paper_model()})
    model, lam = setup.model, setup.lam
    view = large_view(cfg)
    pre = prefiltered(view, PREFILTER)
    actions = np.zeros(view.n_drones, dtype=np.int64)
    limits = [s for s in setup.pyvrp_s if s >= 1.0] or [max(setup.pyvrp_s)]
    runs: list[tuple[str, str, WindowView, Planner]] = [
        ("marops", "all", view, marops_planner(cfg, landing="nearest")),
        ("marops:global", "all", view, marops_planner(cfg, scope="global", landing="nearest")),
        ("marops", f"{PREFILTER:,}", pre, marops_planner(cfg, landing="nearest")),
    ]
    runs += [
        (pyvrp_name(s), f"{PREFILTER:,}", pre, lambda v, a, s=s: pyvrp_routes(v, model, lam, s))
        for s in limits
    ]
    out = []
    for name, given, v, fn in runs:
        routes, wall, cpu = timed(lambda fn=fn, v=v: fn(v, actions))
        sc = score_plan(view, routes, lam)  # judged on the whole window
        out.append(
            {
                "method": name,
                "requests": given,
                "G": sc.G,
                "served": sc.served,
                "cpu_s": cpu,
                "wall_s": wall,
                "broken": check(view, routes, model),
            }
        )
    return out


def print_large(rows: list[dict]) -> None:
    print(
        f"\nlarge window: 64 depots, 100 drones, 10,000 pending, every parcel at every depot;"
        f" PyVRP given the {PREFILTER:,} most delayed; every plan judged on the whole window"
    )
    print(f"{'method':>15} {'requests given':>14}  {'G (MJ)':>8}  served  CPU s  wall s  broken")
    for r in rows:
        print(
            f"{r['method']:>15} {r['requests']:>14}  {r['G'] / 1e6:8.2f}  {r['served']:6d}"
            f"  {r['cpu_s']:5.2f}  {r['wall_s']:6.2f}  {r['broken']}"
        )


# --- the command ----------------------------------------------------------------------


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--config", help="TOML config (default: the realistic operating model)")
    ap.add_argument("--shapes", default="hubs", help="marops synth city shapes, ','-separated")
    ap.add_argument("--seeds", default="101,202", help="marops synth seeds")
    ap.add_argument(
        "--days",
        help="days of August to replay (history: 1..10; default 11,12); with --data the "
        "dates to replay, e.g. 0820,0821 or 0820..0822",
    )
    ap.add_argument(
        "--data",
        metavar="FILES",
        help="LaDe exports (CSV or Parquet, ','-separated) instead of marops synth cities: "
        "each is segmented as marops segment would and replayed on --days",
    )
    ap.add_argument(
        "--pyvrp-s",
        default=",".join(f"{s:g}" for s in PYVRP_S),
        help="PyVRP's limits in the open loop, CPU seconds per window",
    )
    ap.add_argument(
        "--closed-pyvrp-s",
        default=",".join(f"{s:g}" for s in CLOSED_S),
        help="PyVRP's limits in the closed loop (the check is against 0.1 s when given; "
        '"": the open loop alone)',
    )
    ap.add_argument("--open-seeds", help="the open loop on these seeds only (default: --seeds)")
    ap.add_argument("--repeats", type=int, default=1, help="marops plans each window this often")
    ap.add_argument("--bound", action="store_true", help="the bound on G per window and the gaps")
    ap.add_argument(
        "--pyvrp-dest",
        action="store_true",
        help="the open loop also gives PyVRP marops' landings (routing alone compared)",
    )
    ap.add_argument(
        "--bound-labels",
        type=int,
        default=500_000,
        help="labels the bound's search makes at most per window ([plan] bound_labels)",
    )
    ap.add_argument("--large", action="store_true", help="also the large window")
    ap.add_argument("--only-large", action="store_true", help="the large window only")
    ap.add_argument("--closed", action="store_true", help="the closed loop only")
    ap.add_argument(
        "--frontier",
        metavar="ALPHAS",
        help="the closed loop at each α of ALPHAS (e.g. 0.2,0.3,0.5,0.7,0.8,0.9): the points, "
        "PyVRP's points dominated by marops', and the paired per-day differences at each α",
    )
    ap.add_argument("--quiet", action="store_true", help="totals only")
    ap.add_argument("--json", type=Path, metavar="PATH", help="write every figure as JSON")
    ap.add_argument(
        "--variants",
        default="",
        metavar="SETTINGS",
        help="more marops variants: ';'-separated, each ','-separated [plan] settings, e.g. "
        "'pool_urgency=0;pool_iterations=120'",
    )
    ap.add_argument("--smoke", action="store_true", help="1 day, PyVRP 0.01 s, large (CI)")
    args = ap.parse_args(argv)
    if args.data and not args.days:
        ap.error("--data needs --days: the dates to replay, e.g. 0820,0821")
    args.days = args.days or "11,12"
    if args.smoke:
        args.shapes, args.seeds, args.days = "hubs", "101", "11"
        args.pyvrp_s = args.closed_pyvrp_s = "0.01"
        args.quiet, args.large, args.frontier = True, True, "0.5,0.9"
        args.pyvrp_dest = True
    return args


def ints(text: str) -> list[int]:
    return [int(x) for x in text.split(",") if x]


def make_setup(args: argparse.Namespace) -> Setup:
    cfg = load_config(args.config)
    variants = {
        v: dict(x.split("=", 1) for x in v.split(",") if x)
        for v in filter(None, args.variants.split(";"))
    }
    return Setup(
        cfg,
        tuple(float(s) for s in args.pyvrp_s.split(",") if s),
        tuple(float(s) for s in args.closed_pyvrp_s.split(",") if s),
        variants,
        max(1, args.repeats),
        load_bound(override(cfg, plan__bound_labels=args.bound_labels)) if args.bound else None,
        args.pyvrp_dest,
    )


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    # A short search may end on an infeasible solution, whose routes solve_window drops;
    # PyVRP's warning about its penalties would only clutter the tables.
    warnings.filterwarnings("ignore", category=PenaltyBoundWarning)
    setup = make_setup(args)
    # The planner's steady state: the pool's compiled kernels from the first window (a
    # process loads them after a day's windows otherwise), unless MAROPS_JIT=0.
    jit = kernels_now() is not None
    print(f"route pool: {'compiled kernels' if jit else 'numpy'}")
    print(
        f"operating model: stock {setup.cfg.ops.stock}, batteries "
        f"{setup.cfg.ops.batteries_per_depot or 'unlimited'}, busy {setup.cfg.ops.busy}; "
        f"PyVRP limits (CPU s) {', '.join(f'{s:g}' for s in setup.pyvrp_s)}, closed loop "
        f"{', '.join(f'{s:g}' for s in setup.closed_s)}"
    )
    result: dict = {"args": {k: str(v) for k, v in vars(args).items()}}
    open_seeds = {0} if args.data else set(ints(args.open_seeds or args.seeds))
    if not args.only_large:
        opened, closed, frontier_rows = [], [], []
        with tempfile.TemporaryDirectory() as tmp:
            if args.data:
                files = [Path(f) for f in args.data.split(",") if f]
                days = data_days(setup.cfg, files, parse_days(args.days, setup.cfg.data.year))
            else:
                shapes, seeds = args.shapes.split(","), ints(args.seeds)
                days = replay_days(setup.cfg, shapes, seeds, ints(args.days), Path(tmp))
            for day in days:
                print(f"{day.label}:", flush=True)
                if args.frontier:
                    fr = frontier_day(day, setup, [float(a) for a in args.frontier.split(",") if a])
                    frontier_rows += fr
                    for r in fr if not args.quiet else []:
                        print(
                            f"  α {r['alpha']:g} {r['method']:>12} {r['delivered']}/{r['requests']}"
                            f" {r['avg_delay_h']:.3f} h {r['energy_kj'] / 1e3:.2f} MJ"
                            f" J {r['objective_j_mj']:.2f}",
                            flush=True,
                        )
                    if not args.smoke:
                        continue
                if not args.closed and day.seed in open_seeds:
                    opened += open_loop(day, setup, args.quiet)
                if setup.closed_s:  # --closed-pyvrp-s "": the open loop alone
                    closed.append(closed_day(day, setup))
        if opened:
            result["open"] = {"windows": opened, "summary": open_summary(opened, setup)}
            print_open(result["open"]["summary"])
        if frontier_rows:
            result["frontier"] = {"days": frontier_rows, "summary": frontier_summary(frontier_rows)}
            print_frontier(result["frontier"]["summary"])
        if closed:
            result["closed"] = {"days": closed, "summary": closed_summary(closed, setup.ref)}
            print_closed(closed, result["closed"]["summary"])
    if args.large or args.only_large:
        result["large"] = large(setup)
        print_large(result["large"])
    if args.json:
        args.json.write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
