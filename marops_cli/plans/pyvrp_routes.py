"""A window as PyVRP's prize-collecting problem, and PyVRP's routes as marops routes.

PyVRP (the optional ``pyvrp`` extra) is the state-of-the-art open VRP solver. It
serves two roles (docs/method.md, "Route pool"): the peer that ``benchmarks/peer.py``
measures the planner against, and an optional route generator of the pool.

The model of one window's problem (:class:`.problem.WindowProblem`; the problem's
``model`` prices every drone):

* locations: the depots, one dummy end depot, the pending requests;
* one vehicle type per start depot (or per start and fixed end depot, and per set of
  requests the drones may serve), as many vehicles as drones there, capacity = the
  payload limit in grams;
* every request an optional client with prize λ · v_r (v_r = 1 + delay, hours);
* a route ends at the dummy depot, whose distance from a customer is the energy to
  the depot nearest that customer (landing there), unless the end is fixed;
* the battery is a duration limit costed so it never underestimates energy: the leg
  leaving a depot at the full payload limit, the leg leaving customer i at the limit
  less w_i, the last leg empty. Edge "distance" (the cost PyVRP minimises) is the
  same conservative energy, in joules.

Routes PyVRP returns are then re-costed with the exact payload-aware energy model
(:func:`marops_cli.plans.pool.finish_route`), which also improves their order.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .problem import WindowProblem

__all__ = ["PeerRoutes", "available", "solve_window"]

_BIG = 10**12  # "no edge": a leg no route can afford


def available() -> bool:
    """True when PyVRP is installed (``pip install 'marops[pyvrp]'``)."""
    try:
        import pyvrp  # noqa: F401
    except ImportError:
        return False
    return True


@dataclass(frozen=True)
class PeerRoutes:
    """Routes PyVRP found: per route its vehicle's start depot and customer positions."""

    start: NDArray[np.int64]
    end: NDArray[np.int64]
    """End depot per route, -1 where the route lands at the depot nearest its last stop."""
    stops: list[NDArray[np.int64]]
    """Positions in the problem's requests, in PyVRP's order."""
    cost: float
    """PyVRP's own objective (conservative energy minus prizes); infinite when its search
    ended without a feasible solution (its feasible routes are kept all the same)."""


class _CpuLimit:
    """PyVRP's stopping criterion: ``seconds`` of CPU time from its first call."""

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds
        self.end: float | None = None

    def __call__(self, best_cost: float) -> bool:
        now = time.process_time()
        if self.end is None:
            self.end = now + self.seconds
        return now > self.end


def _vehicles(
    problem: WindowProblem,
) -> tuple[NDArray[np.int64], NDArray[np.int64] | None, NDArray[np.bool_] | None]:
    """Each drone's start depot, its end depot (None: every drone lands at the depot
    nearest its last stop; where some end is fixed, a free-landing drone returns to its
    start) and the ``(U, R)`` requests it may serve (None: every drone any request)."""
    tasks = problem.tasks
    allowed = np.zeros((len(tasks), problem.n_requests), dtype=bool)
    for u, t in enumerate(tasks):
        allowed[u, t.allowed] = True
    starts = np.array([t.start for t in tasks], dtype=np.int64)
    ends = np.array([t.end for t in tasks], dtype=np.int64)
    drone_end = None if np.all(ends < 0) else np.where(ends < 0, starts, ends)
    return starts, drone_end, None if allowed.all() else allowed


def solve_window(
    problem: WindowProblem,
    *,
    time_limit_s: float = 1.0,
    iterations: int | None = None,
    seed: int = 0,
) -> PeerRoutes:
    """Solve one window's ``problem`` with PyVRP (see the module docstring for the model):
    each drone a vehicle from its task's start, landing at its task's end and serving
    only its task's requests, each request's prize λ · v. PyVRP stops after
    ``iterations`` when given (the same routes on any machine), else after
    ``time_limit_s`` seconds of this process's CPU time (what a benchmark compares: on
    a shared machine the wall clock also counts other work).
    """
    import pyvrp
    from pyvrp.stop import MaxIterations

    drone_start, drone_end, allowed = _vehicles(problem)
    depots_xy, req_xy, model = problem.depots_xy, problem.xy, problem.model
    n_dep, n_req = depots_xy.shape[0], req_xy.shape[0]
    cap = model.max_payload_kg
    w = np.minimum(np.asarray(problem.weight, dtype=np.float64), cap)
    pts = np.vstack([depots_xy, depots_xy.mean(axis=0, keepdims=True), req_xy])
    n_loc = pts.shape[0]
    dummy = n_dep
    d = np.hypot(pts[:, None, 0] - pts[None, :, 0], pts[:, None, 1] - pts[None, :, 1])
    # Conservative energy per leg by the node it leaves (docstring).
    e_from = np.empty(n_loc)
    e_from[: n_dep + 1] = float(model.energy_per_m(cap))
    e_from[n_dep + 1 :] = model.energy_per_m(np.clip(cap - w, 0.0, cap))
    energy = d * e_from[:, None]
    # The dummy end: from a customer, the empty leg to its nearest depot.
    d_near = d[n_dep + 1 :, :n_dep].min(axis=1)
    energy[:, dummy] = _BIG
    energy[n_dep + 1 :, dummy] = d_near * float(model.energy_per_m(0.0))
    energy[:n_dep, dummy] = 0.0  # an unused vehicle
    energy[dummy, :] = _BIG
    energy[dummy, dummy] = 0.0
    # Fixed ends: the last leg to that depot is flown empty.
    if drone_end is not None:
        e0 = float(model.energy_per_m(0.0))
        energy[n_dep + 1 :, :n_dep] = d[n_dep + 1 :, :n_dep] * e0
    np.fill_diagonal(energy, 0.0)
    base = np.ceil(energy).astype(np.int64)

    starts = np.asarray(drone_start, dtype=np.int64)
    ends = None if drone_end is None else np.asarray(drone_end, dtype=np.int64)
    keys: dict[tuple[int, int, bytes], int] = {}
    members: list[list[int]] = []
    for u in range(starts.size):
        key = (
            int(starts[u]),
            -1 if ends is None else int(ends[u]),
            b"" if allowed is None else np.packbits(allowed[u]).tobytes(),
        )
        if key not in keys:
            keys[key] = len(members)
            members.append([])
        members[keys[key]].append(u)
    matrices, vtypes, type_keys = [], [], list(keys)
    usable = int(np.floor(model.usable_j))
    if allowed is None:
        matrices.append(base)  # one routing profile shared by every vehicle type
    for k, key in enumerate(type_keys):
        s, e, _ = key
        if allowed is not None:  # a profile per type: what it may not serve is out of reach
            ok = allowed[members[k][0]]
            mat = base.copy()
            mat[:, n_dep + 1 :][:, ~ok] = _BIG
            mat[n_dep + 1 :, :][~ok, :] = _BIG
            np.fill_diagonal(mat, 0)  # PyVRP wants a zero diagonal, reachable or not
            matrices.append(mat)
        vtypes.append(
            pyvrp.VehicleType(
                num_available=len(members[k]),
                capacity=[int(round(cap * 1000))],
                start_depot=s,
                end_depot=dummy if e < 0 else e,
                shift_duration=usable,
                profile=0 if allowed is None else k,
            )
        )
    locations = [pyvrp.Location(float(x), float(y)) for x, y in pts]
    depots = [pyvrp.Depot(i) for i in range(n_dep + 1)]
    grams = np.ceil(w * 1000 - 1e-9).astype(np.int64)  # never under the real weight
    prizes = np.round(problem.lam * np.asarray(problem.value, dtype=np.float64)).astype(np.int64)
    clients = [
        pyvrp.Client(n_dep + 1 + i, delivery=[int(grams[i])], prize=int(prizes[i]), required=False)
        for i in range(n_req)
    ]
    data = pyvrp.ProblemData(locations, clients, depots, vtypes, matrices, matrices)
    stop = _CpuLimit(time_limit_s) if iterations is None else MaxIterations(iterations)
    res = pyvrp.solve(data, stop=stop, seed=seed, collect_stats=False, display=False)
    best = res.best
    out_start, out_end, out_stops = [], [], []
    for route in best.routes():
        if not route.is_feasible():  # a short run may end on an infeasible solution
            continue
        visits = [a.idx for a in route if a.is_client()]  # client indices
        if not visits:
            continue
        s, e, _ = type_keys[route.vehicle_type()]
        out_start.append(s)
        out_end.append(e)
        out_stops.append(np.asarray(visits, dtype=np.int64))
    return PeerRoutes(
        start=np.asarray(out_start, dtype=np.int64),
        end=np.asarray(out_end, dtype=np.int64),
        stops=out_stops,
        cost=float(res.cost()),
    )
