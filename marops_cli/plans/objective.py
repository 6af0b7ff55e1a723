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

__all__ = ["WindowScore", "lam_j", "relative_gap", "score_routes"]


def lam_j(alpha: float, energy_ref_j: float) -> float:
    """λ = ((1 − α)/α) · E_ref: joules per unit of v left unserved."""
    if not 0 < alpha <= 1:
        raise ValueError(f"expected alpha in (0, 1], got {alpha}")
    return (1.0 - alpha) / alpha * float(energy_ref_j)


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
