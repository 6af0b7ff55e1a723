"""The delay–energy–delivered frontier over α (docs/outputs.md, "Frontier").

α is the dial of the window objective: a high α prices delay low, so plans wait for
parcels to gather and fly less energy per parcel; a low α flies sooner. An evaluation
over several α gives each method one operating point per α, pooled over the days (and
hubs and repeats): parcels delivered per replay, the average delivery delay of every
request, energy per replay and per delivered parcel. A point is *dominated* when
another point of the same fleet and areas — of any method, at any α — delivers at
least as many parcels, at no more delay and no more energy, and is better in one of
the three: no weight makes a dominated point the one to pick.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyarrow as pa

__all__ = ["FRONTIER_ALPHAS", "FRONTIER_FILE", "dominated_by", "frontier_table"]

FRONTIER_ALPHAS = (0.2, 0.3, 0.5, 0.7, 0.8, 0.9)
"""``evaluate --frontier``'s grid of α."""
FRONTIER_FILE = "frontier.csv"
"""The frontier table in an evaluation's folder."""
_GROUP = ("drones", "coverage", "depots_n", "n_actions")
"""What must be equal for two points to be compared: the fleet and the service areas."""
_NEED = ("delivered", "requests", "avg_delay_h", "energy_kj", "objective_j_mj")


def frontier_table(results: pa.Table) -> pa.Table | None:
    """One row per fleet-and-areas group × method × α, pooled over the replays, with
    ``dominated`` and ``dominated_by``; None when no group has two values of α (or the
    results lack a metric the frontier needs)."""
    if not set(_NEED) <= set(results.column_names) or results.num_rows == 0:
        return None
    rows = results.select([*_GROUP, "alpha", "method", *_NEED]).to_pylist()
    points: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in rows:
        points.setdefault((*(r[g] for g in _GROUP), r["method"], r["alpha"]), []).append(r)
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for key, reps in points.items():
        groups.setdefault(key[: len(_GROUP)], []).append(_pooled(key, reps))
    if not any(len({p["alpha"] for p in ps}) > 1 for ps in groups.values()):
        return None
    out: list[dict[str, Any]] = []
    for ps in groups.values():
        flags = dominated_by(
            [(p["delivered"], p["avg_delay_h"], p["energy_kj"]) for p in ps],
        )
        for p, by in zip(ps, flags, strict=True):
            p["dominated"] = by is not None
            p["dominated_by"] = "" if by is None else _label(ps[by])
            out.append(p)
    return pa.Table.from_pylist(out)


def _pooled(key: tuple[Any, ...], reps: list[dict[str, Any]]) -> dict[str, Any]:
    """One operating point: means per replay, the delay averaged over every request."""
    n = len(reps)
    delivered = float(sum(r["delivered"] for r in reps))
    requests = float(sum(r["requests"] for r in reps))
    energy = float(sum(r["energy_kj"] for r in reps))
    delay = sum(r["avg_delay_h"] * r["requests"] for r in reps) / max(requests, 1.0)
    return {
        **dict(zip(_GROUP, key[: len(_GROUP)], strict=True)),
        "method": key[len(_GROUP)],
        "alpha": float(key[len(_GROUP) + 1]),
        "replays": n,
        "delivered": delivered / n,
        "delivered_share": delivered / requests if requests else 1.0,
        "avg_delay_h": float(delay),
        "energy_kj": energy / n,
        "energy_per_parcel_kj": energy / delivered if delivered else float("nan"),
        "objective_j_mj": float(np.mean([r["objective_j_mj"] for r in reps])),
    }


def _label(p: dict[str, Any]) -> str:
    return f"{p['method']} α={p['alpha']:g}"


def dominated_by(points: list[tuple[float, float, float]]) -> list[int | None]:
    """For each (delivered, delay, energy) point, the index of a point that dominates it
    (delivered ≥, delay ≤, energy ≤, one of them strictly), or None. Of several, the one
    that delivers most, then with the least delay, then energy, then the first."""
    arr = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    out: list[int | None] = []
    for d, t, e in arr:
        dom = (
            (arr[:, 0] >= d)
            & (arr[:, 1] <= t)
            & (arr[:, 2] <= e)
            & ((arr[:, 0] > d) | (arr[:, 1] < t) | (arr[:, 2] < e))
        )
        idx = np.flatnonzero(dom)
        if not idx.size:
            out.append(None)
            continue
        best = np.lexsort((idx, arr[idx, 2], arr[idx, 1], -arr[idx, 0]))[0]
        out.append(int(idx[best]))
    return out
