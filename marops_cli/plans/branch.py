"""A small branch and bound over the selection's linear relaxation.

The selection program (:mod:`.select`) has a few hundred 0/1 columns and a relaxation
that is integral on most windows and a few branchings from integral on the rest.
HiGHS' integer solver spends 10–25 ms on such a program whatever it holds (presolve,
clique table, cuts at the root); re-solving the relaxation with one column fixed takes
a tenth of a millisecond from the previous basis. So the selection first branches
itself: depth first, the fractional column of the largest value fixed to 1 first (then
to 0), a node pruned when its relaxation cannot beat the best plan found by more than
the program's relative gap. Past ``max_nodes`` relaxations, or at the deadline (CPU
seconds), it gives up and the caller runs HiGHS' integer solver (docs/decisions.md, "Planning a
window").
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import highspy
import numpy as np
from numpy.typing import NDArray

from .highs import run_highs

__all__ = ["Branched", "branch_and_bound"]

MAX_NODES = 1_000
"""Relaxations solved at most before the integer solver takes over."""


@dataclass(frozen=True)
class Branched:
    """The best 0/1 solution and a proven lower bound on the program's objective."""

    x: NDArray[np.float64]
    objective: float
    bound: float
    nodes: int


def branch_and_bound(
    h: highspy.Highs,
    rel_gap: float,
    integral_tol: float,
    deadline: float,
    max_nodes: int | None = None,
) -> Branched | None:
    """Minimise ``h``'s model (its relaxation just solved to optimality, fractional)
    over 0/1 columns; None when ``max_nodes`` or ``deadline`` (``time.thread_time``,
    this thread's CPU seconds: the same search on a busy machine) is reached first, or
    a relaxation ends other than optimal or infeasible. The model's column bounds are
    left as they were (``max_nodes`` None: :data:`MAX_NODES`)."""
    cap = MAX_NODES if max_nodes is None else max_nodes
    n = h.getNumCol()
    best, best_x, lower = np.inf, None, np.inf
    stack: list[tuple[tuple[int, float], ...]] = [()]
    fixed: tuple[tuple[int, float], ...] = ()
    nodes = 0
    try:
        while stack:
            node = stack.pop()
            if nodes and (nodes >= cap or time.thread_time() > deadline):
                return None
            _fix(h, fixed, node)
            fixed = node
            if nodes:  # the root's relaxation is solved already
                run_highs(h)
            nodes += 1
            status = h.getModelStatus()
            if status == highspy.HighsModelStatus.kInfeasible:
                continue
            if status != highspy.HighsModelStatus.kOptimal:
                return None
            obj = float(h.getInfo().objective_function_value)
            if best_x is not None and obj >= best - rel_gap * max(abs(best), 1e-9):
                lower = min(lower, obj)  # nothing better below this node
                continue
            x = np.asarray(h.getSolution().col_value, dtype=np.float64)[:n]
            frac = np.abs(x - np.round(x))
            if frac.max(initial=0.0) <= integral_tol:
                best, best_x = obj, np.round(x)
                continue
            j = int(np.argmax(np.where(frac > integral_tol, x, -1.0)))
            stack.append((*node, (j, 0.0)))
            stack.append((*node, (j, 1.0)))
    finally:
        _fix(h, fixed, ())
    if best_x is None:
        return None
    return Branched(best_x, best, min(best, lower), nodes)


def _fix(
    h: highspy.Highs,
    old: tuple[tuple[int, float], ...],
    new: tuple[tuple[int, float], ...],
) -> None:
    """Free the columns ``old`` fixed, then fix those of ``new``."""
    if old:
        idx = np.array([c for c, _ in old], dtype=np.int32)
        h.changeColsBounds(idx.size, idx, np.zeros(idx.size), np.ones(idx.size))
    if new:
        idx = np.array([c for c, _ in new], dtype=np.int32)
        val = np.array([v for _, v in new], dtype=np.float64)
        h.changeColsBounds(idx.size, idx, val, val)
