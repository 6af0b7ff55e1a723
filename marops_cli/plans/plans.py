"""Candidate plans (docs/method.md §4, paper Alg. 2 lines 4–12) and their table across drones.

A plan is a subset of the drone's candidates that fits the payload limit, flown
start → its customers (in the chosen visiting order) → end. The empty plan (fly
start → end with nothing) is always plan 0.

Decision: when even the empty plan exceeds the usable battery, the destination is
out of reach and every plan is (payload only adds energy, and by the triangle
inequality a detour only adds distance); :func:`build_plans` then raises
:class:`NoFeasiblePlanError` rather than return a drone with no plan, because the
selection program needs exactly one plan per drone. Callers should pick a reachable
destination (``EnergyModel.max_range_m()``) or fall back to staying at the start.

:class:`SelectionProblem` gathers every drone's :class:`PlanSet` into the table that
the selection program (``select.py``) works on: plan energies, the request × plan
incidence, v_c = 1 + delay_c and λ = ((1 − α)/α) · E_ref.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from ..config import PlanConfig
from ..energy import EnergyModel
from .objective import lam_j
from .order import subset_orders

__all__ = ["Candidates", "NoFeasiblePlanError", "PlanSet", "SelectionProblem", "build_plans"]


class NoFeasiblePlanError(ValueError):
    """The flight start → end alone needs more than the usable battery."""


@dataclass(frozen=True)
class PlanSet:
    """Feasible plans of one drone; plan 0 is the empty plan.

    Columns of ``members`` and values of ``order`` are candidate positions: index
    ``request_ids`` to get the requests.
    """

    request_ids: NDArray[np.int64]
    """``(n,)`` the drone's candidate requests."""
    members: NDArray[np.bool_]
    """``(K, n)`` plan ``k`` serves candidate ``j``."""
    order: NDArray[np.int8] | NDArray[np.int16]
    """``(K, n)`` candidate positions in visiting order, padded with -1."""
    energy_j: NDArray[np.float64]
    """``(K,)`` route energy (eqs. (4)–(9))."""
    distance_m: NDArray[np.float64]
    """``(K,)`` route length."""
    weight_kg: NDArray[np.float64]
    """``(K,)`` parcel weight taken at the start depot."""

    @property
    def n_plans(self) -> int:
        return int(self.energy_j.size)

    @property
    def n_candidates(self) -> int:
        return int(self.request_ids.size)

    def stops(self, k: int) -> tuple[int, ...]:
        """Candidate positions of plan ``k`` in visiting order."""
        return tuple(int(j) for j in self.order[k] if j >= 0)

    def route(self, k: int) -> tuple[int, ...]:
        """Request ids of plan ``k`` in visiting order."""
        return tuple(int(self.request_ids[j]) for j in self.stops(k))


@dataclass(frozen=True)
class Candidates:
    """A drone's candidate requests: where each is, what it weighs and its request id."""

    xy: ArrayLike
    """``(n, 2)`` metres."""
    weight_kg: ArrayLike
    """``(n,)`` kilograms."""
    ids: ArrayLike | None = None
    """``(n,)`` the requests' ids (the plans' :attr:`PlanSet.request_ids`); None:
    ``0..n-1``."""


def build_plans(
    start_xy: ArrayLike,
    end_xy: ArrayLike,
    candidates: Candidates,
    model: EnergyModel,
    cfg: PlanConfig | None = None,
) -> PlanSet:
    """Every feasible plan of one drone flying start → end over its ``candidates``.

    Feasible: at most ``cfg.max_parcels`` stops, weight within the payload limit
    (eq. (16)), energy within the usable battery (the battery limit of eq. (15), in
    joules). Plans are listed by bitmask, so the empty plan comes first; visiting order
    per ``cfg.ordering``.

    Raises
    ------
    NoFeasiblePlanError
        If the empty flight start → end exceeds the usable battery.
    """
    cfg = cfg or PlanConfig()
    w = np.asarray(candidates.weight_kg, dtype=np.float64).reshape(-1)
    ids = (
        np.arange(w.size, dtype=np.int64)
        if candidates.ids is None
        else np.asarray(candidates.ids, dtype=np.int64).reshape(-1)
    )
    if ids.size != w.size:
        raise ValueError(f"expected {w.size} request ids, got {ids.size}")
    if np.unique(ids).size != ids.size:
        raise ValueError("expected distinct request ids")
    subsets = subset_orders(start_xy, end_xy, candidates.xy, w, model, cfg.ordering)
    if subsets.energy_j[0] > model.usable_j:
        raise NoFeasiblePlanError(
            f"the flight start -> end alone ({subsets.distance_m[0]:.0f} m, "
            f"{subsets.energy_j[0]:.0f} J) exceeds the usable battery ({model.usable_j:.0f} J)"
        )
    keep = (
        (subsets.size <= cfg.max_parcels)
        & model.fits(subsets.weight_kg)
        & (subsets.energy_j <= model.usable_j)
    )
    masks = np.flatnonzero(keep)
    members = ((masks[:, None] >> np.arange(w.size)) & 1).astype(bool)
    return PlanSet(
        request_ids=ids,
        members=members,
        order=subsets.order[masks],
        energy_j=subsets.energy_j[masks],
        distance_m=subsets.distance_m[masks],
        weight_kg=subsets.weight_kg[masks],
    )


@dataclass(frozen=True)
class SelectionProblem:
    """All drones' plans in one table: plan ``k`` of drone ``u`` is column ``offsets[u] + k``.

    Plan 0 of every drone is its empty plan, so the relaxed program is always feasible.
    """

    energy_j: NDArray[np.float64]
    """``(P,)`` energy E_uk of each plan."""
    offsets: NDArray[np.int64]
    """``(U + 1,)`` first column of each drone's plans."""
    cover: sp.csr_matrix
    """``(R, P)`` 1 where the plan serves the request (rows: ``request_ids``)."""
    request_ids: NDArray[np.int64]
    """``(R,)`` every candidate of every drone, sorted."""
    value: NDArray[np.float64]
    """``(R,)`` v_c = 1 + delay_c in hours."""
    lam: float
    """λ = ((1 − α)/α) · E_ref, joules per unit of v_c left unserved."""

    @classmethod
    def of(
        cls, plan_sets: Sequence[PlanSet], value: NDArray[np.float64], lam: float
    ) -> SelectionProblem:
        """Assemble drones' plan sets whose request ids are window positions; ``value``
        holds v_c of every position (a window problem's ``priced``), ``lam`` λ."""
        _check_empty_plans(plan_sets)
        ids = _request_ids(plan_sets)
        return cls._table(plan_sets, ids, np.asarray(value, dtype=np.float64)[ids], lam)

    @classmethod
    def from_plan_sets(
        cls,
        plan_sets: Sequence[PlanSet],
        delay_h: Mapping[int, float],
        *,
        alpha: float,
        energy_ref_j: float,
    ) -> SelectionProblem:
        """Assemble drones' plan sets; ``delay_h`` maps every candidate id to its delay,
        λ from ``alpha`` and ``energy_ref_j`` (:func:`.objective.lam_j`)."""
        _check_empty_plans(plan_sets)
        lam = lam_j(alpha, energy_ref_j)
        ids = _request_ids(plan_sets)
        missing = [int(i) for i in ids if int(i) not in delay_h]
        if missing:
            raise ValueError(f"expected a delay for every candidate, missing {missing[:5]}")
        value = 1.0 + np.array([float(delay_h[int(i)]) for i in ids])
        return cls._table(plan_sets, ids, value, lam)

    @classmethod
    def _table(
        cls,
        plan_sets: Sequence[PlanSet],
        ids: NDArray[np.int64],
        value: NDArray[np.float64],
        lam: float,
    ) -> SelectionProblem:
        """The table of ``plan_sets`` over the requests ``ids`` (sorted) of value ``value``."""
        sizes = np.array([ps.n_plans for ps in plan_sets], dtype=np.int64)
        offsets = np.concatenate([[0], np.cumsum(sizes)])
        rows, cols = [], []
        for u, ps in enumerate(plan_sets):
            k, j = np.nonzero(ps.members)
            rows.append(np.searchsorted(ids, ps.request_ids[j]))
            cols.append(offsets[u] + k)
        r, c = np.concatenate(rows), np.concatenate(cols)
        cover = sp.csr_matrix((np.ones(r.size), (r, c)), shape=(ids.size, int(offsets[-1])))
        return cls(
            energy_j=np.concatenate([ps.energy_j for ps in plan_sets]).astype(np.float64),
            offsets=offsets,
            cover=cover,
            request_ids=ids,
            value=value,
            lam=lam,
        )

    @property
    def n_drones(self) -> int:
        return int(self.offsets.size - 1)

    @property
    def n_plans(self) -> int:
        return int(self.offsets[-1])

    @cached_property
    def drone(self) -> NDArray[np.int64]:
        """``(P,)`` the drone owning each plan."""
        return np.repeat(np.arange(self.n_drones), np.diff(self.offsets))

    @cached_property
    def cost(self) -> NDArray[np.float64]:
        """``(P,)`` per-plan cost c_uk = E_uk − λ Σ_{c ∈ p_uk} v_c."""
        return self.energy_j - self.lam * (self.cover.T @ self.value)

    @property
    def constant(self) -> float:
        return float(self.lam * self.value.sum())

    def columns(self, chosen: NDArray[np.int64]) -> NDArray[np.int64]:
        return self.offsets[:-1] + np.asarray(chosen, dtype=np.int64)

    def objective(self, chosen: NDArray[np.int64]) -> float:
        """Σ E x + λ Σ v (1 − y) of a selection (local plan index per drone)."""
        return float(self.cost[self.columns(chosen)].sum() + self.constant)

    def violation(self, chosen: NDArray[np.int64]) -> str | None:
        """Why ``chosen`` is not a valid selection, or None when it is."""
        chosen = np.asarray(chosen)
        if chosen.shape != (self.n_drones,):
            return f"expected one plan per drone ({self.n_drones}), got shape {chosen.shape}"
        if np.any(chosen < 0) or np.any(chosen >= np.diff(self.offsets)):
            return "plan index out of range"
        served = self.served(chosen)
        if np.any(served > 1):
            twice = self.request_ids[served > 1]
            return f"requests served twice: {twice[:5].tolist()}"
        return None

    def served(self, chosen: NDArray[np.int64]) -> NDArray[np.int64]:
        """``(R,)`` how many chosen plans serve each request (y_c)."""
        x = np.zeros(self.n_plans)
        x[self.columns(chosen)] = 1.0
        return np.rint(self.cover @ x).astype(np.int64)

    def uncoverable(self) -> NDArray[np.int64]:
        """Requests that no plan serves (they make the strict cover infeasible)."""
        return self.request_ids[np.diff(self.cover.indptr) == 0]


def _check_empty_plans(plan_sets: Sequence[PlanSet]) -> None:
    """Raise ``ValueError`` unless there is a drone and each drone's plan 0 is empty."""
    if not plan_sets:
        raise ValueError("expected at least one drone")
    for u, ps in enumerate(plan_sets):
        if ps.n_plans == 0 or ps.members[0].any():
            raise ValueError(f"expected plan 0 of drone {u} to be the empty plan")


def _request_ids(plan_sets: Sequence[PlanSet]) -> NDArray[np.int64]:
    """Every candidate of every drone, sorted."""
    return np.unique(np.concatenate([ps.request_ids for ps in plan_sets]).astype(np.int64))
