"""What the drones know at the start of a window: the planner's input (docs/method.md §5).

It lives with the plans, which read it; the policies and the simulator build and pass
it (imports run one way: data, segment, plans, policies, sim).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..energy import EnergyModel
from ..segment.depots import Depots
from .ranges import Ties

__all__ = ["EVERY_DEPOT", "FREE", "WindowView"]

FREE = -1
"""The action "no destination" (docs/method.md §4.1): with the route pool the drone lands
at the depot nearest its last customer (an idle drone stays); the paper's planner flies
it as action 0."""

EVERY_DEPOT = -1
"""``WindowView.pending_stock`` of a parcel held at every depot (the paper)."""


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
    drone_models: tuple[EnergyModel, ...]
    """(U,) each drone's energy model, its type's (docs/method.md §5.1); with one type
    every entry is that type's."""
    pending_stock: np.ndarray
    """(P,) the depot each pending parcel is stocked at: a drone carries only its departure
    depot's (docs/method.md, "Operating model"); :data:`EVERY_DEPOT` where a parcel is at
    every depot (the paper)."""
    drone_ready: np.ndarray
    """(U,) False where a drone cannot fly this window (still on a long flight, or no
    charged battery at its depot): it gets only its empty plan and stays."""
    depot_spares: np.ndarray
    """(N,) charged spare batteries at each depot at the start of the window, before its
    swaps; ``inf`` where a charged battery waits whenever one is needed (the paper)."""
    depot_charging: np.ndarray
    """(N,) batteries on charge or waiting for a charger at each depot (0 under the paper's
    unlimited swaps)."""
    ties: Ties = "nearest"  # candidate order among equally delayed requests (PlanConfig.ties)
    pending_visible_w: np.ndarray | None = None  # (P,) window each became visible; None: unknown
    pending_servable: np.ndarray | None = None
    """(P,) False where no drone of the fleet can ever serve the request (too heavy for
    every type, or out of every type's reach from the nearest depot); None: not known."""

    @classmethod
    def paper(cls, model: EnergyModel | None = None, **fields: Any) -> WindowView:
        """A view whose operating state is the paper's wherever it is not given (or is
        None): every drone of ``model``'s type (default: the default drone) unless
        ``drone_models`` are given, every parcel at every depot (``pending_stock``), every
        drone able to fly (``drone_ready``), swaps unlimited (``depot_spares``,
        ``depot_charging``). ``fields``: the view's others, and those it gives."""
        n_drones = len(fields["drone_depot"])
        n_req, n_depots = len(fields["pending_idx"]), len(fields["depots"])
        drone_models: Sequence[EnergyModel] | None = fields.pop("drone_models", None)
        pending_stock = fields.pop("pending_stock", None)
        drone_ready = fields.pop("drone_ready", None)
        depot_spares = fields.pop("depot_spares", None)
        depot_charging = fields.pop("depot_charging", None)
        if drone_models is None:
            drone_models = (model or EnergyModel(),) * n_drones
        return cls(
            drone_models=tuple(drone_models),
            pending_stock=np.full(n_req, EVERY_DEPOT, np.int64)
            if pending_stock is None
            else np.asarray(pending_stock, dtype=np.int64),
            drone_ready=np.ones(n_drones, bool) if drone_ready is None else drone_ready,
            depot_spares=np.full(n_depots, np.inf) if depot_spares is None else depot_spares,
            depot_charging=np.zeros(n_depots) if depot_charging is None else depot_charging,
            **fields,
        )

    @property
    def swaps_unlimited(self) -> bool:
        """A charged battery waits at every depot whenever one is needed (the paper)."""
        return bool(np.isinf(self.depot_spares).all())

    @property
    def n_drones(self) -> int:
        return int(self.drone_depot.shape[0])

    def waiting_at(self) -> np.ndarray:
        """(P,) the depot each pending parcel waits at: where it is stocked, its service
        area's depot when it is at every depot."""
        return np.where(self.pending_stock == EVERY_DEPOT, self.pending_area, self.pending_stock)

    def ready(self, u: int) -> bool:
        """Whether drone ``u`` can fly this window."""
        return bool(self.drone_ready[u])

    def action_mask(self) -> np.ndarray:
        """``(U, A)`` True where the action exists (a depot has fewer candidates when N < A)."""
        n_cand = self.depots.candidates.shape[1]
        return np.ones((self.n_drones, n_cand), dtype=bool)
