"""The layout-independent observation of a drone (SPEC §6), versioned.

One block of features per action candidate, so a trained actor works on any
segmentation with the same number of actions; distances in km and counts
scaled to order one so one network fits many cities.
"""

from __future__ import annotations

import numpy as np

from .base import WindowView

OBS_VERSION = 1
PER_ACTION = 6  # features per action candidate
GLOBAL = 4  # time of day, own-area pending, own-area delay, total pending


def obs_dim(n_actions: int) -> int:
    return n_actions * PER_ACTION + GLOBAL


def observe(view: WindowView) -> np.ndarray:
    """``(U, obs_dim)`` float32 observations, one row per drone.

    Per action candidate a of drone u (start s, destination d = candidates[s, a]):
    distance s→d (km), pending count in the flight range, summed delay in the
    range (h), requests due now or overdue in the range, summed delay in the
    destination's neighbour areas (h), and a valid flag. Then time of day
    (fraction of the service day), pending and delay in the drone's own area,
    and the total pending on the map.
    """
    dep = view.depots
    n, a = dep.candidates.shape
    area_count = np.bincount(view.pending_area, minlength=n).astype(np.float64)
    area_delay = np.bincount(view.pending_area, weights=view.pending_delay_h, minlength=n)
    due_now = (view.pending_due_w <= view.t).astype(np.float64)
    area_due = np.bincount(view.pending_area, weights=due_now, minlength=n)
    # Delay around each depot: the areas of its own candidate list, itself excluded.
    neigh_delay = area_delay[dep.candidates[:, 1:]].sum(axis=1) if a > 1 else np.zeros(n)

    out = np.zeros((view.n_drones, obs_dim(a)), dtype=np.float32)
    for u, s in enumerate(view.drone_depot):
        s = int(s)
        for k in range(a):
            d = int(dep.candidates[s, k])
            rng = view.ranges[s, k]
            f = out[u, k * PER_ACTION : (k + 1) * PER_ACTION]
            f[0] = np.hypot(*(dep.xy[d] - dep.xy[s])) / 1000.0
            f[1] = area_count[rng].sum() / 10.0
            f[2] = area_delay[rng].sum() / 10.0
            f[3] = area_due[rng].sum() / 10.0
            f[4] = neigh_delay[d] / 10.0
            f[5] = 1.0
        g = out[u, a * PER_ACTION :]
        g[0] = view.t / max(1, view.n_windows)
        g[1] = area_count[s] / 10.0
        g[2] = area_delay[s] / 10.0
        g[3] = area_count.sum() / 100.0
    return out
