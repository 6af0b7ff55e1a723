"""What the drones know at the start of a window: the planner's input (docs/method.md §5).

It lives with the plans, which read it; the policies and the simulator build and pass
it (imports run one way: data, segment, plans, policies, sim).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..energy import EnergyModel
from ..segment.depots import Depots
from .ranges import Ties

__all__ = ["FREE", "WindowView"]

FREE = -1
"""The action "no destination" (docs/method.md §4.1): with the route pool the drone lands
at the depot nearest its last customer (an idle drone stays); the paper's planner flies
it as action 0."""


@dataclass
class WindowView:
    """What the drones know at the start of window ``t`` (paper §IV-B, the state).

    ``pending_*`` arrays describe the visible, undelivered requests; ``ranges`` is
    the ``(N, A, N)`` flight-range table of :func:`marops_cli.plans.ranges.range_table`.
    """

    t: int
    n_windows: int
    window_h: float
    depots: Depots
    ranges: np.ndarray
    drone_depot: np.ndarray  # (U,) depot id of each drone
    pending_idx: np.ndarray  # (P,) index of each pending request in the day's arrays
    pending_xy: np.ndarray  # (P, 2) metres
    pending_area: np.ndarray  # (P,) service area (depot id)
    pending_delay_h: np.ndarray  # (P,)
    pending_due_w: np.ndarray  # (P,)
    pending_due_s: np.ndarray  # (P,) due time, seconds from service start
    pending_weight: np.ndarray  # (P,)
    ties: Ties = "nearest"  # candidate order among equally delayed requests (PlanConfig.ties)
    pending_visible_w: np.ndarray | None = None  # (P,) window each became visible; None: unknown
    drone_models: tuple[EnergyModel, ...] | None = None
    """(U,) each drone's energy model, its type's (docs/method.md §5.1); None: one type,
    the planner's model."""
    pending_stock: np.ndarray | None = None
    """(P,) the depot each pending parcel is stocked at: a drone carries only its departure
    depot's (docs/method.md, "Operating model"); None: every parcel at every depot (the
    paper)."""
    pending_servable: np.ndarray | None = None
    """(P,) False where no drone of the fleet can ever serve the request (too heavy for
    every type, or out of every type's reach from the nearest depot); None: not known."""
    drone_ready: np.ndarray | None = None
    """(U,) False where a drone cannot fly this window (still on a long flight, or no
    charged battery at its depot): it gets only its empty plan and stays; None: all can."""
    depot_spares: np.ndarray | None = None
    """(N,) charged spare batteries at each depot at the start of the window, before its
    swaps; None: a charged battery at every depot whenever one is needed (the paper)."""
    depot_charging: np.ndarray | None = None
    """(N,) batteries on charge or waiting for a charger at each depot; None: unlimited."""

    @property
    def n_drones(self) -> int:
        return int(self.drone_depot.shape[0])

    def stocked_at(self, s: int) -> np.ndarray | None:
        """Pending positions a drone departing from depot ``s`` may carry; None: all."""
        if self.pending_stock is None:
            return None
        return np.flatnonzero(self.pending_stock == s).astype(np.int64)

    def ready(self, u: int) -> bool:
        """Whether drone ``u`` can fly this window."""
        return self.drone_ready is None or bool(self.drone_ready[u])

    def action_mask(self) -> np.ndarray:
        """``(U, A)`` True where the action exists (a depot has fewer candidates when N < A)."""
        n_cand = self.depots.candidates.shape[1]
        return np.ones((self.n_drones, n_cand), dtype=bool)
