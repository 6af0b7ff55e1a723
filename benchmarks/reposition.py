"""Does repositioning ahead of demand pay? A probe for what the learned actor could learn.

A hand-made rule, ``reposition``: every drone lands free (at the depot nearest its last
customer) unless the best plan it could fly is worth at most ``--idle`` (battery units of
net value, observation feature 10 of the free block); such an idle drone flies to the
destination with the most arrivals expected around it over the next two windows (the
history days' arrival profile, docs/method.md §6) per drone already there, less 0.5 per
km of flight. Compared, paired per day, with ``ops-global`` (every drone lands free) on
the held-out cities of ``benchmarks/heldout.py`` (seeds 41–44, four shapes, 10 days each,
16 areas, α 0.5). If this rule cannot beat landing free, there is little for a learned
repositioning to earn on these cities.

    python benchmarks/reposition.py [--drones 8,16] [--idle 0.0] [--smoke]

``--smoke``: one city of 2 replayed days, 8 drones (CI runs it so the script keeps up
with the library).
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402
from heldout import KEYS, SEEDS, held_out_cities  # noqa: E402  (the same held-out cities)


def reposition_policy(idle: float) -> Any:
    from marops_cli.energy import EnergyModel
    from marops_cli.policies.base import PolicyBase
    from marops_cli.policies.observation import VALUE, SequentialObserver, per_action, to_actions

    class Reposition(PolicyBase):
        name = "reposition"

        def configure(self, cfg: Any) -> None:
            self.model, self.plan = EnergyModel(cfg.energy), cfg.plan

        def act(self, view: Any) -> np.ndarray:
            seq = SequentialObserver(view, self.model, self.plan, version=4)
            a, per = view.depots.candidates.shape[1], per_action(4)
            out = np.zeros(view.n_drones, dtype=np.int64)
            for u in range(view.n_drones):
                row = seq.row(u)
                choice = a  # the free landing
                if row[a * per + VALUE] <= idle:
                    score = [
                        np.expm1(row[k * per + 14]) / (1.0 + np.expm1(row[k * per + 17]))
                        - 0.5 * row[k * per]
                        for k in range(a)
                    ]
                    choice = int(np.argmax(score))
                out[u] = choice
                seq.commit(u, choice)
            return to_actions(out, a)

    return Reposition()


def _job(task: tuple[Any, ...]) -> list[dict[str, Any]]:
    os.environ["OMP_NUM_THREADS"] = "1"
    from marops_cli.config import PlannerConfig, override
    from marops_cli.data.reader import read_lade
    from marops_cli.sim.scenario import load_fleet, load_scenario, method_policy, replay

    path, shape, drones, method, idle = task
    cfg = override(PlannerConfig(), segment__n_depots=16, sim__drones=drones)
    table = read_lade(path, cfg.data)
    days = table.days()[4:]
    scn = load_scenario(path, cfg, replay_days=days, table=table)
    fleet = load_fleet(None, scn.depots, drones, cfg)
    pol = reposition_policy(idle) if method == "reposition" else method_policy(method, None, 0)
    rows = []
    for d in days:
        _, _, m = replay(scn, d, fleet, pol, "marops" if method == "reposition" else method)
        rows.append({"shape": shape, "drones": drones, "method": method, "day": str(d),
                     **{k: float(m[k]) for k in KEYS}})  # fmt: skip
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--drones", default="8,16")
    ap.add_argument(
        "--idle", type=float, default=0.0, help="net value at or below which a drone is idle"
    )
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--smoke", action="store_true", help="one city, 2 days, 8 drones (CI)")
    args = ap.parse_args()
    from marops_cli.evaluate.paired import bootstrap_ci

    shapes, days = (["hubs"], 6) if args.smoke else (list(SEEDS), 14)
    if args.smoke:
        args.drones = "8"
    files = {s: f for (s, _), f in held_out_cities(shapes, days, "marops-reposition-").items()}
    fleets = [int(x) for x in args.drones.split(",")]
    tasks = [
        (str(files[s]), s, u, m, args.idle)
        for s in files
        for u in fleets
        for m in ("reposition", "ops-global")
    ]
    with mp.get_context("spawn").Pool(args.workers) as pool:
        rows = [r for part in pool.map(_job, tasks, chunksize=1) for r in part]
    print("reposition − ops-global, paired per day, mean [95 % CI]; 16 areas, α 0.5")
    for u in fleets:
        for s in [*files, "all"]:
            pick = [r for r in rows if r["drones"] == u and s in ("all", r["shape"])]
            a = {(r["shape"], r["day"]): r for r in pick if r["method"] == "reposition"}
            b = {(r["shape"], r["day"]): r for r in pick if r["method"] == "ops-global"}
            cells = []
            for k in KEYS:
                d = np.array([a[x][k] - b[x][k] for x in sorted(a)])
                lo, hi = bootstrap_ci(d)
                cells.append(f"{k} {d.mean():+.3f} [{lo:+.3f}, {hi:+.3f}]")
            print(f"{u:2d} drones  {s:12s}  " + "  ".join(cells))


if __name__ == "__main__":
    main()
