"""Segmentation methods: k-means (paper Alg. 1) and the squares baseline (docs/method.md §2)."""

from __future__ import annotations

import numpy as np

from ..config import SegmentConfig
from ..data.frame import Frame
from ..errors import SettingError
from .depots import Depots, nearest_candidates


def kmeans_depots(x: np.ndarray, y: np.ndarray, frame: Frame, cfg: SegmentConfig) -> Depots:
    """Depots at the k-means centroids of the history customer locations."""
    pts = np.column_stack([x, y]).astype(np.float64)
    # k-means++ seeds by row index: the points in a canonical order, so an export's row
    # order (a database dump's is arbitrary) does not move the depots.
    pts = pts[np.lexsort((pts[:, 1], pts[:, 0]))]
    distinct = np.unique(pts, axis=0).shape[0]
    if distinct < cfg.n_depots:
        held = (
            f"{pts.shape[0]} history requests"
            if pts.shape[0] < cfg.n_depots
            else f"{distinct} distinct history locations"
        )
        raise SettingError(
            f"{cfg.n_depots} depots asked for, but the study area of {{data}} holds only "
            f"{held} (--n-depots)",
            key="segment.n_depots",
        )
    # Imported here: scikit-learn (and the scipy.stats it pulls in) costs most of a
    # second that a replay with a depots file never needs.
    from sklearn.cluster import KMeans
    from threadpoolctl import threadpool_limits

    km = KMeans(n_clusters=cfg.n_depots, n_init=cfg.n_init, random_state=cfg.seed)
    # One thread: k-means' OpenMP reductions sum in an order that depends on the thread
    # count, which moved the centroids' last bits (and so the routes) between machines.
    with threadpool_limits(limits=1):
        km.fit(pts)
    # Millimetres, as depots.json stores them: a replay that segments in memory and one
    # that reads the depots file plan on the very same depots.
    centers = np.round(km.cluster_centers_, 3)
    # Order depots south-west to north-east so ids read naturally on a map and do
    # not depend on k-means' internal label order.
    order = np.lexsort((centers[:, 0], np.round(centers[:, 1], 3)))
    centers = centers[order]
    return _finish("kmeans", frame, centers, pts, cfg)


def squares_depots(x: np.ndarray, y: np.ndarray, frame: Frame, cfg: SegmentConfig) -> Depots:
    """A regular sqrt(N) x sqrt(N) grid over the study square, depots at cell centres."""
    side = round(cfg.n_depots**0.5)
    cell = 2.0 * frame.half_m / side
    c = -frame.half_m + cell * (np.arange(side) + 0.5)
    gx, gy = np.meshgrid(c, c)  # row-major from the south-west corner
    centers = np.column_stack([gx.ravel(), gy.ravel()])
    pts = np.column_stack([x, y]).astype(np.float64)
    return _finish("squares", frame, centers, pts, cfg)


def _finish(
    method: str, frame: Frame, centers: np.ndarray, pts: np.ndarray, cfg: SegmentConfig
) -> Depots:
    depots = Depots(
        method=method,
        frame=frame,
        xy=np.ascontiguousarray(centers, dtype=np.float64),
        n_history=np.zeros(centers.shape[0], dtype=np.int64),
        candidates=nearest_candidates(centers, cfg.n_actions),
    )
    depots.n_history = np.bincount(depots.assign(pts[:, 0], pts[:, 1]), minlength=len(depots))
    return depots


def segment_points(x: np.ndarray, y: np.ndarray, frame: Frame, cfg: SegmentConfig) -> Depots:
    """Dispatch on ``cfg.method``."""
    if cfg.method == "squares":
        return squares_depots(x, y, frame, cfg)
    return kmeans_depots(x, y, frame, cfg)
