"""The layout-independent observation of a drone (SPEC §6), versioned.

One block of features per action candidate, so a trained actor works on any
segmentation with the same number of actions. Distances are in km; counts and
delays go through ``log1p`` so that one network fits a quiet suburb and a busy
city centre alike (a linear scale saturates the tanh units in one or the other).

Version history: 1 = six linear features per action; 2 = adds what the planner
would actually get for each action (its M̂ candidates' delay, count and detour),
how crowded the range is with other drones, and the map-wide overdue load.
"""

from __future__ import annotations

import numpy as np

from ..plans.ranges import pick_candidates
from .base import WindowView

OBS_VERSION = 2
PER_ACTION = 10  # features per action candidate
GLOBAL = 7  # time, own area (2), map (2), drones sharing my depot, fleet density
M_HAT = 5  # candidates per drone the features assume (PlanConfig.max_parcels default)


def obs_dim(n_actions: int) -> int:
    return n_actions * PER_ACTION + GLOBAL


def _lg(x: float | np.ndarray) -> float | np.ndarray:
    return np.log1p(np.maximum(x, 0.0))


def _candidate_features(
    view: WindowView, s: int, d: int, rng: np.ndarray, m_hat: int
) -> tuple[float, float, float]:
    """Summed delay (h), count and mean detour (km) of the M̂ requests the planner
    would pick in range ``rng`` (same rule as :func:`pick_candidates`)."""
    inside = np.flatnonzero(rng[view.pending_area])
    if inside.size == 0:
        return 0.0, 0.0, 0.0
    xy_s, xy_d = view.depots.xy[s], view.depots.xy[d]
    pxy = view.pending_xy[inside]
    dist_s = np.hypot(*(pxy - xy_s).T)
    cand = pick_candidates(
        np.arange(inside.size),
        view.pending_delay_h[inside],
        view.pending_due_s[inside],
        dist_s,
        m_hat,
    )
    detour = dist_s[cand] + np.hypot(*(pxy[cand] - xy_d).T) - np.hypot(*(xy_d - xy_s))
    return float(view.pending_delay_h[inside][cand].sum()), float(cand.size), float(detour.mean())


def observe(view: WindowView, m_hat: int = M_HAT) -> np.ndarray:
    """``(U, obs_dim)`` float32 observations, one row per drone.

    Per action candidate a of drone u (start s, destination d = candidates[s, a],
    flight range R = ranges[s, a]):

    0. distance s→d (km)
    1. log1p pending requests in R
    2. log1p summed delay in R (h)
    3. log1p requests due now or overdue in R
    4. log1p summed delay in the areas around d (its other candidates)
    5. valid flag (1)
    6. log1p other drones whose depot lies in R (crowding: they compete for R)
    7. log1p summed delay of the M̂ requests the planner would take in R (h)
    8. how many of those there are, / M̂
    9. their mean detour s→c→d minus s→d (km): what serving them costs

    Then: time of day (fraction of the day), log1p pending and delay in the own
    area, log1p pending and overdue delay on the whole map, drones at the same
    depot with a lower index (breaks the tie between co-located drones, which
    otherwise see the same thing and would pick the same action), and drones per
    depot.
    """
    dep = view.depots
    n, a = dep.candidates.shape
    area_count = np.bincount(view.pending_area, minlength=n).astype(np.float64)
    area_delay = np.bincount(view.pending_area, weights=view.pending_delay_h, minlength=n)
    due_now = (view.pending_due_w <= view.t).astype(np.float64)
    area_due = np.bincount(view.pending_area, weights=due_now, minlength=n)
    # Delay around each depot: the areas of its own candidate list, itself excluded.
    neigh_delay = area_delay[dep.candidates[:, 1:]].sum(axis=1) if a > 1 else np.zeros(n)
    drones_at = np.bincount(view.drone_depot, minlength=n).astype(np.float64)

    out = np.zeros((view.n_drones, obs_dim(a)), dtype=np.float32)
    for u, s in enumerate(view.drone_depot):
        s = int(s)
        for k in range(a):
            d = int(dep.candidates[s, k])
            rng = view.ranges[s, k]
            cand_delay, cand_n, detour = _candidate_features(view, s, d, rng, m_hat)
            f = out[u, k * PER_ACTION : (k + 1) * PER_ACTION]
            f[0] = np.hypot(*(dep.xy[d] - dep.xy[s])) / 1000.0
            f[1] = _lg(area_count[rng].sum())
            f[2] = _lg(area_delay[rng].sum())
            f[3] = _lg(area_due[rng].sum())
            f[4] = _lg(neigh_delay[d])
            f[5] = 1.0
            f[6] = _lg(drones_at[rng].sum() - 1.0)  # minus u itself: s is always in R
            f[7] = _lg(cand_delay)
            f[8] = cand_n / m_hat
            f[9] = detour / 1000.0
        g = out[u, a * PER_ACTION :]
        g[0] = view.t / max(1, view.n_windows)
        g[1] = _lg(area_count[s])
        g[2] = _lg(area_delay[s])
        g[3] = _lg(area_count.sum())
        g[4] = _lg(view.pending_delay_h.sum())
        g[5] = _lg(float(np.count_nonzero(view.drone_depot[:u] == s)))
        g[6] = view.n_drones / max(1, n)
    return out
