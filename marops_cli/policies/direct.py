"""The MAPPO baseline (docs/method.md §7): a learned policy picks each drone's plan directly.

Action space: destination × plan slot, ``a = dest · S + slot`` with ``S`` plan
slots (default 4). The destination works as in MAR-OPS (it sets the flight
range, hence the M̂ candidates and the plans); the slot then names one plan of
that drone's plan set without any optimiser:

* slots ``0 .. S−2``: the drone's non-empty plans ranked by the delay value they
  serve (Σ v_c, v_c = 1 + delay in h), highest first; ties go to the cheaper
  plan, then to the lower plan index, so the ranking is deterministic. A slot
  past the last non-empty plan takes the last one.
* slot ``S−1``: the empty plan (fly to the destination with nothing).

Conflicts go to the first drone that claimed the request (drone order): a later
drone flies the subset of its plan that is still free, which is itself a plan
of its set (dropping a stop never adds payload or distance).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..plans.plans import SelectionProblem
from ..plans.select import SelectionResult, SelectionStatus
from .base import SLOT_PLANNER
from .torchscript import TorchScriptPolicy

DEFAULT_SLOTS = 4


def ranked_plans(problem: SelectionProblem, u: int) -> NDArray[np.int64]:
    """Local indices of drone ``u``'s non-empty plans, best value first."""
    lo, hi = int(problem.offsets[u]), int(problem.offsets[u + 1])
    served = problem.cover[:, lo:hi].T @ problem.value
    energy = problem.energy_j[lo:hi]
    local = np.arange(hi - lo)
    order = np.lexsort((local, energy, -served))
    return order[order != 0].astype(np.int64)  # plan 0 is the empty plan


def slot_plan(problem: SelectionProblem, u: int, slot: int, n_slots: int) -> int:
    """The local plan index that ``slot`` names for drone ``u``."""
    ranked = ranked_plans(problem, u)
    if slot >= n_slots - 1 or ranked.size == 0:
        return 0
    return int(ranked[min(slot, ranked.size - 1)])


@dataclass(frozen=True, eq=False)
class SlotSelector:
    """A :class:`~marops_cli.plans.select.Selector` that flies the plan in each drone's slot;
    conflicts go to the drone with the lower index."""

    n_slots: int = DEFAULT_SLOTS
    slots: NDArray[np.int64] | None = None
    """Each drone's slot in the window it selects for; None: slot 0 (the best plan)."""

    def picking(self, slots: np.ndarray) -> SlotSelector:
        """This selector flying ``slots`` (one per drone)."""
        return SlotSelector(self.n_slots, np.asarray(slots, dtype=np.int64))

    def select(self, problem: SelectionProblem) -> SelectionResult:
        t0 = time.perf_counter()
        n = problem.n_drones
        slots = np.zeros(n, dtype=np.int64) if self.slots is None else self.slots
        claimed = np.zeros(problem.request_ids.size, dtype=bool)
        chosen = np.zeros(n, dtype=np.int64)
        cover = problem.cover.tocsc()
        for u in range(n):
            lo, hi = int(problem.offsets[u]), int(problem.offsets[u + 1])
            k = slot_plan(problem, u, int(slots[u]), self.n_slots)
            want = cover[:, lo + k].toarray().ravel() > 0
            free = want & ~claimed
            if not np.array_equal(free, want):
                # First claim wins: fly the plan that serves exactly the free part.
                members = cover[:, lo:hi].toarray() > 0
                match = np.flatnonzero((members == free[:, None]).all(axis=0))
                k = int(match[0]) if match.size else 0
                free = members[:, k]
            chosen[u] = k
            claimed |= free
        return SelectionResult.without_solver(problem, chosen, SelectionStatus.DIRECT, t0)


class DirectPolicy(TorchScriptPolicy):
    """Arg-max of a TorchScript actor over destination × plan slot (the MAPPO baseline).

    The sidecar names ``plan_slots``; :meth:`act` returns the chosen slots with the
    actions (:class:`~.base.SlotActions`), and :attr:`selector`, which the window planner
    uses instead of the optimiser, flies them.
    """

    scope: Literal["range", "global"] = "range"
    planner: str | None = SLOT_PLANNER  # its slots rank the paper's subset plans

    def __init__(self, path: str | Path, *, trust: bool = False) -> None:
        super().__init__(path, slots=SlotSelector, trust=trust)
        self.name = f"mappo:{self.path.name}"
