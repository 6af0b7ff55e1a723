"""The window objective that judges any planner (docs/method.md, "The window objective").

For the pending, visible requests of a window, with v_r = 1 + delay_r (hours) and
λ = ((1 − α)/α) · E_ref (E_ref = the usable battery):

    J = Σ route energy + λ Σ_{pending r} v_r (1 − served_r)      (lower is better)
    G = λ Σ_{served r} v_r − Σ route energy                        (higher is better)

so J = λ Σ_pending v − G: G is the part a planner controls. The selection program
minimises exactly J over the routes it is given.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "WindowScore",
    "lam_j",
    "priced_delay_h",
    "relative_gap",
    "score_routes",
    "wait_credit_j",
]


def lam_j(alpha: float, energy_ref_j: float) -> float:
    """λ = ((1 − α)/α) · E_ref: joules per unit of v left unserved."""
    if not 0 < alpha <= 1:
        raise ValueError(f"expected alpha in (0, 1], got {alpha}")
    return (1.0 - alpha) / alpha * float(energy_ref_j)


def priced_delay_h(
    delay_h: NDArray[np.float64], last_window: bool, night_h: float
) -> NDArray[np.float64]:
    """The delay (hours) the route pool prices each pending request at (docs/method.md
    §4.4, "The day's end"): its delay, and in the day's last window the night too
    (``night_h``), which a parcel left then waits before the next day's first window."""
    d = np.asarray(delay_h, dtype=np.float64)
    return d + night_h if last_window and night_h > 0 else d


def wait_credit_j(
    xy: NDArray[np.float64], depots_xy: NDArray[np.float64], e0_j_per_m: float
) -> NDArray[np.float64]:
    """What waiting does not save of each pending request's flight (docs/method.md §4.4,
    "What waiting saves"): a request left now is flown later all the same, and even in
    the best route then it costs at least a detour there and back from its nearest
    neighbour — another pending request or a depot, whichever is nearer — which this
    prices empty: 2 · that distance · the empty drone's energy per metre (J)."""
    from scipy.spatial import cKDTree

    pts = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    dep = np.asarray(depots_xy, dtype=np.float64).reshape(-1, 2)
    near = cKDTree(dep).query(pts, k=1)[0] if dep.size else np.full(len(pts), np.inf)
    if len(pts) > 1:
        near = np.minimum(near, cKDTree(pts).query(pts, k=2)[0][:, 1])
    near = np.where(np.isfinite(near), near, 0.0)
    return 2.0 * near * float(e0_j_per_m)


def relative_gap(bound: float, g: float) -> float:
    """(bound − G) / |bound|: the share of a bound on G that a plan of objective ``g``
    misses (docs/method.md, "The bound")."""
    return (bound - g) / max(abs(bound), 1e-9)


@dataclass(frozen=True)
class WindowScore:
    """J and G of one window's routes, with what goes into them."""

    J: float
    G: float
    energy_j: float
    served: int
    pending: int
    served_value: float
    """Σ v_r over the served requests."""
    pending_value: float
    """Σ v_r over every pending request."""
    bound_G: float | None = None
    """A proven upper bound on G over every feasible plan (docs/method.md, "The bound");
    None when not computed."""

    @property
    def gap(self) -> float | None:
        """(bound − G) / |bound|: how far G may be from the best plan; None without a bound."""
        return None if self.bound_G is None else relative_gap(self.bound_G, self.G)

    def with_bound(self, bound_g: float) -> WindowScore:
        """This score with its bound."""
        return replace(self, bound_G=float(bound_g))

    def as_dict(self) -> dict[str, float | int]:
        out: dict[str, float | int] = {
            "J": self.J,
            "G": self.G,
            "energy_j": self.energy_j,
            "served": self.served,
            "pending": self.pending,
        }
        if self.bound_G is not None:  # only with the bound on: default outputs unchanged
            out["bound_G"] = self.bound_G
            out["gap"] = float(self.gap)  # type: ignore[arg-type]
        return out


def score_routes(
    pending_idx: NDArray[np.int64],
    pending_delay_h: NDArray[np.float64],
    routes: Iterable[tuple[Iterable[int], float]],
    lam: float,
) -> WindowScore:
    """J and G of routes given as ``(stops as day indices, energy_j)`` pairs.

    ``pending_idx`` / ``pending_delay_h`` describe the window's pending requests; a stop
    that is not pending raises ``ValueError`` (a route cannot serve what is not there).
    """
    value = 1.0 + np.asarray(pending_delay_h, dtype=np.float64)
    pos = {int(i): k for k, i in enumerate(np.asarray(pending_idx).tolist())}
    served = np.zeros(value.size, dtype=bool)
    energy = 0.0
    for stops, e in routes:
        energy += float(e)
        for s in stops:
            k = pos.get(int(s))
            if k is None:
                raise ValueError(f"request {int(s)} is not pending in this window")
            if served[k]:
                raise ValueError(f"request {int(s)} served twice")
            served[k] = True
    total = float(value.sum())
    got = float(value[served].sum())
    g = lam * got - energy
    return WindowScore(
        J=lam * total - g,
        G=g,
        energy_j=energy,
        served=int(served.sum()),
        pending=int(value.size),
        served_value=got,
        pending_value=total,
    )
