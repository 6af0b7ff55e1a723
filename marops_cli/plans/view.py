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

    @property
    def n_drones(self) -> int:
        return int(self.drone_depot.shape[0])

    def action_mask(self) -> np.ndarray:
        """``(U, A)`` True where the action exists (a depot has fewer candidates when N < A)."""
        n_cand = self.depots.candidates.shape[1]
        return np.ones((self.n_drones, n_cand), dtype=bool)
