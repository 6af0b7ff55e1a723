"""The flight-range policy protocol and the window view that policies read."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, Protocol, runtime_checkable

import numpy as np

from ..plans.ranges import Ties
from ..segment.depots import Depots

if TYPE_CHECKING:
    from ..config import PlanConfig, PlannerConfig


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

    @property
    def n_drones(self) -> int:
        return int(self.drone_depot.shape[0])

    def action_mask(self) -> np.ndarray:
        """``(U, A)`` True where the action exists (a depot has fewer candidates when N < A)."""
        n_cand = self.depots.candidates.shape[1]
        return np.ones((self.n_drones, n_cand), dtype=bool)


@runtime_checkable
class Policy(Protocol):
    """Chooses each drone's destination among its depot's action candidates.

    ``scope`` is ``"range"`` for the paper's flight ranges and ``"global"`` for the
    whole-map baseline (the planner then ignores the actions).
    """

    name: str
    scope: Literal["range", "global"]

    def reset(self, seed: int) -> None:
        """Start a new day (recurrent state, random streams)."""
        ...

    def act(self, view: WindowView) -> np.ndarray:
        """Action index (0 = stay) for every drone, shape ``(U,)``."""
        ...


def start_day(policy: Policy, cfg: PlannerConfig, seed: int) -> None:
    """Hand a policy the run's planner settings, if it plans ahead (``configure``), and
    start its day (``reset``)."""
    configure = getattr(policy, "configure", None)
    if configure is not None:
        configure(cfg)
    policy.reset(seed)


def plan_config(policy: object, plan: PlanConfig) -> PlanConfig:
    """The plan settings ``policy`` flies with: a policy that picks plans itself (the MAPPO
    baseline, trained on the paper's subsets) names its ``planner``; others use ``plan``."""
    planner = getattr(policy, "planner", None)
    if planner is None or planner == plan.planner:
        return plan
    return plan.model_copy(update={"planner": planner})
