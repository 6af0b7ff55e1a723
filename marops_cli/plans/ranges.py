"""Flight ranges and each drone's candidate requests Ĉ_u (docs/method.md §4.1, Alg. 2 line 2)."""

from __future__ import annotations

from typing import Literal

import numpy as np

from ..segment.depots import Depots

Ties = Literal["nearest", "due"]


def range_size(n_depots: int, coverage: float) -> int:
    """Areas in a flight range: max(2, round(coverage · N)), at most N."""
    return int(min(n_depots, max(2, round(coverage * n_depots))))


def flight_range(depots: Depots, start: int, dest: int, coverage: float) -> np.ndarray:
    """Boolean mask over service areas: start and destination areas, then the areas
    nearest the start-destination midpoint until the range holds ``range_size`` areas.

    With start == destination the range grows around the start depot.
    """
    n = len(depots)
    size = range_size(n, coverage)
    mid = (depots.xy[start] + depots.xy[dest]) / 2.0
    d = np.hypot(depots.xy[:, 0] - mid[0], depots.xy[:, 1] - mid[1])
    mask = np.zeros(n, dtype=bool)
    mask[start] = mask[dest] = True
    for j in np.lexsort((np.arange(n), d)):  # nearest first, ties to the lower id
        if mask.sum() >= size:
            break
        mask[j] = True
    return mask


def range_table(depots: Depots, coverage: float) -> np.ndarray:
    """``(N, A, N)`` masks: the flight range of every depot's every action."""
    n, a = depots.candidates.shape
    table = np.zeros((n, a, n), dtype=bool)
    for s in range(n):
        for k in range(a):
            table[s, k] = flight_range(depots, s, int(depots.candidates[s, k]), coverage)
    return table


def delays_h(due_w: np.ndarray, t: int, window_h: float) -> np.ndarray:
    """Delay of undelivered requests at window t: (t − t_i)·window_hours if t ≥ t_i (eq. 3)."""
    return np.maximum(0, t - due_w).astype(np.float64) * window_h


def pick_candidates(
    idx: np.ndarray,
    delay: np.ndarray,
    due_s: np.ndarray,
    dist_to_start: np.ndarray,
    m_hat: int,
    ties: Ties = "nearest",
) -> np.ndarray:
    """The ``m_hat`` requests of ``idx`` with the highest delay, most delayed first.

    Delay counts whole windows, so many requests tie on it. Ties ``"nearest"``: nearer
    the start depot, then earlier due time; ``"due"`` (docs/method.md §4): earlier due time, then
    nearer. Then the lower index, so the choice never depends on array order. All
    arrays are aligned with ``idx``.
    """
    keys = (dist_to_start, due_s) if ties == "due" else (due_s, dist_to_start)
    return idx[np.lexsort((idx, *keys, -delay))[:m_hat]]
