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
    """``(N, A, N)`` masks: the flight range of every depot's every action, each the
    mask :func:`flight_range` gives, found for many start-destination pairs at once (a
    Python loop over areas made a window of 4,096 depots take 40 s to start)."""
    n, a = depots.candidates.shape
    size = range_size(n, coverage)
    xy = depots.xy
    starts = np.repeat(np.arange(n), a)
    dests = depots.candidates.reshape(-1).astype(np.int64)
    table = np.zeros((n * a, n), dtype=bool)
    step = max(1, (1 << 20) // n)  # pairs at a time: about a million distances
    for lo in range(0, n * a, step):
        s, t = starts[lo : lo + step], dests[lo : lo + step]
        rows = np.arange(s.size)
        mid = (xy[s] + xy[t]) / 2.0
        d = np.hypot(xy[None, :, 0] - mid[:, None, 0], xy[None, :, 1] - mid[:, None, 1])
        d[rows, s] = d[rows, t] = -np.inf  # start and destination first, then nearest
        # The ``size`` first areas by distance, ties to the lower id: those nearer than
        # the size-th distance, then the lowest ids at that distance to fill the range.
        kth = np.partition(d, size - 1, axis=1)[:, size - 1 : size]
        near = d < kth
        tied = d == kth
        fill = size - near.sum(axis=1, keepdims=True)
        table[lo : lo + s.size] = near | (tied & (np.cumsum(tied, axis=1) <= fill))
    return table.reshape(n, a, n)


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
