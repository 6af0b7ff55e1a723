"""Each drone's candidate requests Ĉ_u in its flight range (docs/method.md §4.1, Alg. 2 line 2).

The one candidate rule of the paper's planner; the actor's observation (docs/method.md §6)
calls the same functions, so what it shows for an action is what the planner would take.
"""

from __future__ import annotations

import numpy as np

from .ranges import pick_candidates
from .view import WindowView

__all__ = ["by_delay", "draft", "range_candidates"]


def by_delay(view: WindowView) -> np.ndarray:
    """Pending positions by delay (highest first), then due time, then position: the
    ranking :func:`range_candidates` reads."""
    return np.lexsort((view.pending_due_s, -view.pending_delay_h))


def range_candidates(
    view: WindowView, rank: np.ndarray, rank_area: np.ndarray, s: int, a: int, m_hat: int
) -> np.ndarray:
    """Ĉ_u of a drone at depot ``s`` taking action ``a``: pending positions in its range.

    ``rank`` lists the pending requests by delay (highest first), then due time
    (:func:`by_delay`, or a subset of it in that order), and ``rank_area`` their areas,
    so only the head of the drone's range needs the full sort of :func:`pick_candidates`
    (with its distance tie-breaks): the first ``m_hat`` requests and any tied with the
    last of them (on delay, and on due time when ``view.ties`` is ``"due"``).
    """
    inside = rank[view.ranges[s, a][rank_area]]
    if inside.size > m_hat:
        last, rest = inside[m_hat - 1], inside[m_hat:]
        tie = view.pending_delay_h[rest] == view.pending_delay_h[last]
        if view.ties == "due":
            tie &= view.pending_due_s[rest] == view.pending_due_s[last]
        inside = inside[: m_hat + (tie.size if tie.all() else int(np.argmin(tie)))]
    dist = np.hypot(*(view.pending_xy[inside] - view.depots.xy[s]).T)
    return pick_candidates(
        inside, view.pending_delay_h[inside], view.pending_due_s[inside], dist, m_hat, view.ties
    )


def draft(prefs: list[np.ndarray], n_items: int, m_hat: int) -> list[np.ndarray]:
    """Snake draft: in M̂ rounds (forward, then backward order) each drone claims its most
    preferred unclaimed item; then a drone left short tops up, in its own order, with
    items others claimed. ``prefs[u]`` lists drone u's items, most preferred first."""
    n_u = len(prefs)
    claimed = np.zeros(n_items, dtype=bool)
    picks: list[list[int]] = [[] for _ in range(n_u)]
    ptr = [0] * n_u
    for rnd in range(m_hat):
        for u in range(n_u) if rnd % 2 == 0 else range(n_u - 1, -1, -1):
            pref = prefs[u]
            while ptr[u] < pref.size and claimed[pref[ptr[u]]]:
                ptr[u] += 1
            if ptr[u] < pref.size:
                picks[u].append(int(pref[ptr[u]]))
                claimed[pref[ptr[u]]] = True
    out = []
    for u in range(n_u):
        mine = picks[u]
        if len(mine) < m_hat:
            taken = set(mine)
            mine = mine + [int(i) for i in prefs[u] if int(i) not in taken][: m_hat - len(mine)]
        out.append(np.array(mine, dtype=np.int64))
    return out
