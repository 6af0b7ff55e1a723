"""The study area's metric frame: a local equirectangular projection (docs/method.md §1).

Around the study area's centre, x points east and y north, in metres. Over a
10 km square the scale error of this projection stays under 0.05 % at LaDe's
latitudes (it grows with the square of the distance from the centre line), well
inside the 0.1 % the planner needs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, SettingError

EARTH_RADIUS_M = 6_371_008.8  # mean Earth radius (IUGG)


@dataclass(frozen=True)
class Frame:
    """A square study area of side ``size_km`` centred on (``center_lng``, ``center_lat``)."""

    center_lng: float
    center_lat: float
    size_km: float

    @property
    def half_m(self) -> float:
        return self.size_km * 500.0

    @property
    def _kx(self) -> float:
        return EARTH_RADIUS_M * math.cos(math.radians(self.center_lat)) * math.pi / 180.0

    @property
    def _ky(self) -> float:
        return EARTH_RADIUS_M * math.pi / 180.0

    def to_xy(self, lng: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Degrees -> metres in this frame. Longitudes are taken the short way round, so
        a study area across the antimeridian (180°) holds the requests on both sides."""
        x = (_wrap(np.asarray(lng, dtype=np.float64) - self.center_lng)) * self._kx
        y = (np.asarray(lat, dtype=np.float64) - self.center_lat) * self._ky
        return x, y

    def to_lnglat(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Metres in this frame -> degrees (longitudes in -180..180)."""
        lng = _wrap(np.asarray(x, dtype=np.float64) / self._kx + self.center_lng)
        lat = np.asarray(y, dtype=np.float64) / self._ky + self.center_lat
        return lng, lat

    def contains(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Boolean mask of points inside the square (edges included)."""
        h = self.half_m
        return (np.abs(x) <= h) & (np.abs(y) <= h)

    def to_dict(self) -> dict[str, float]:
        return {
            "center_lng": float(self.center_lng),
            "center_lat": float(self.center_lat),
            "size_km": float(self.size_km),
        }


def _wrap(deg: np.ndarray) -> np.ndarray:
    """Longitudes (or their differences) brought into -180..180; values already there are
    returned untouched, to the last bit."""
    out = np.where(deg > 180.0, deg - 360.0, deg)
    return np.where(out < -180.0, out + 360.0, out)


def _median_lng(lng: np.ndarray) -> float:
    """The median longitude, or, for a city across the antimeridian whose plain median
    falls on the far side of the globe, the median taken on 0..360."""
    plain = float(np.median(lng))
    if np.abs(_wrap(lng - plain)).min() * 111.32 <= 150.0:
        return plain
    return float(_wrap(np.array(np.median(np.mod(lng, 360.0)))))


REACH_M = 150_000.0
"""How far from the points' median (east-west and north-south) a study area or a hub
is sought: points beyond it (another city, a bad fix) would only blow up the grid."""


def within_reach(
    lng: np.ndarray, lat: np.ndarray, of_lng: np.ndarray, of_lat: np.ndarray
) -> np.ndarray:
    """Mask of the points ``lng, lat`` within :data:`REACH_M` (east-west and north-south)
    of the median of ``of_lng, of_lat``, as a study area or a hub is sought."""
    ref = Frame(_median_lng(np.asarray(of_lng)), float(np.median(of_lat)), 1.0)
    x, y = ref.to_xy(np.asarray(lng, dtype=np.float64), np.asarray(lat, dtype=np.float64))
    return (np.abs(x) <= REACH_M) & (np.abs(y) <= REACH_M)


MAX_GRID_CELLS = 16_000_000
"""Cells the densest-square search may count (128 MB, and as much for its sums): a 10 m
step over 40 km."""


def _square_grid(
    lng: np.ndarray, lat: np.ndarray, size_km: float, grid_m: float
) -> tuple[Frame, float, float, np.ndarray, int]:
    """``(ref, x0, y0, counts (ny, nx), k)``: points binned on a ``grid_m`` grid around
    their median, and the side ``k`` of a ``size_km`` square in cells."""
    lng = np.asarray(lng, dtype=np.float64)
    lat = np.asarray(lat, dtype=np.float64)
    if lng.size == 0:
        raise ValueError("no points to place a study area on")
    ref = Frame(_median_lng(lng), float(np.median(lat)), size_km)
    x, y = ref.to_xy(lng, lat)
    keep = (np.abs(x) <= REACH_M) & (np.abs(y) <= REACH_M)
    if not keep.any():
        raise InputError(
            f"the requests are scattered: none lies within {REACH_M / 1000:g} km of their "
            "median position "
            f"({ref.center_lng:.3f}, {ref.center_lat:.3f}); place the study area with [data] "
            "center in a config file (segment: --center), or plan each city from a file of "
            "its own",
            column="lng",
        )
    x, y = x[keep], y[keep]
    x0, y0 = float(x.min()), float(y.min())
    ix = np.floor((x - x0) / grid_m).astype(np.int64)
    iy = np.floor((y - y0) / grid_m).astype(np.int64)
    k = max(1, int(round(size_km * 1000.0 / grid_m)))
    nx = max(int(ix.max()) + 1, k)
    ny = max(int(iy.max()) + 1, k)
    if nx * ny > MAX_GRID_CELLS:  # a fine step over a wide city: gigabytes, not an answer
        need = grid_m * np.sqrt(nx * ny / MAX_GRID_CELLS)
        raise SettingError(
            f"the densest-square search would need a {ny:,} × {nx:,} grid over these "
            f"requests; use a step of at least {np.ceil(need):.0f} m, or place the study area "
            "with [data] center",
            key="data.grid_m",
        )
    counts = np.zeros((ny, nx), dtype=np.int64)
    np.add.at(counts, (iy, ix), 1)
    return ref, x0, y0, counts, k


def _window_sums(grid: np.ndarray, k: int) -> np.ndarray:
    """Sum of every k x k square of whole cells (2-D prefix sum)."""
    ny, nx = grid.shape
    prefix = np.zeros((ny + 1, nx + 1), dtype=np.int64)
    prefix[1:, 1:] = grid.cumsum(0).cumsum(1)
    return prefix[k:, k:] - prefix[:-k, k:] - prefix[k:, :-k] + prefix[:-k, :-k]


def _square_frame(
    ref: Frame, x0: float, y0: float, jy: int, jx: int, k: int, grid_m: float, size_km: float
) -> Frame:
    cx = x0 + (jx + k / 2.0) * grid_m
    cy = y0 + (jy + k / 2.0) * grid_m
    clng, clat = ref.to_lnglat(np.array([cx]), np.array([cy]))
    return Frame(float(clng[0]), float(clat[0]), size_km)


def _densest_pick(window: np.ndarray, k: int) -> tuple[int, int]:
    """The densest of the squares ``window`` scores (their counts on the grid padded by
    ``k - 1`` cells, so a square may hang over the points' edge). Where several tie (a
    town smaller than the square: every square around it holds it all), the one in the
    middle of the tied squares that overlap the south-west-most, so the town sits in
    the square's middle, not in its corner; ties of that to the first in row-major
    order."""
    ty, tx = np.nonzero(window == window.max())  # row-major: south-west first
    near = (np.abs(ty - ty[0]) < k) & (np.abs(tx - tx[0]) < k)
    ty, tx = ty[near], tx[near]
    far = (ty - ty.mean()) ** 2 + (tx - tx.mean()) ** 2
    i = int(np.argmin(far))
    return int(ty[i]), int(tx[i])


def densest_square(
    lng: np.ndarray, lat: np.ndarray, size_km: float, grid_m: float = 250.0
) -> Frame:
    """The ``size_km`` square holding the most points, on a ``grid_m`` grid (reproducible).

    Points are binned on a grid around their median; every square of whole grid
    cells is scored with a 2-D prefix sum; of squares that tie, the middle one of
    those overlapping the south-west-most (:func:`_densest_pick`).
    """
    ref, x0, y0, counts, k = _square_grid(lng, lat, size_km, grid_m)
    pad = k - 1
    jy, jx = _densest_pick(_window_sums(np.pad(counts, pad), k), k)
    return _square_frame(ref, x0, y0, jy - pad, jx - pad, k, grid_m, size_km)


def hub_squares(
    lng: np.ndarray,
    lat: np.ndarray,
    size_km: float,
    grid_m: float = 250.0,
    n_hubs: int | None = None,
    min_share: float = 0.01,
    cover: bool = False,
) -> list[tuple[Frame, int]]:
    """Disjoint ``size_km`` squares over a city, densest first (docs/method.md §1.1):
    the first is :func:`densest_square`'s; each next one is the densest square that
    shares no grid cell with those before. Stops after ``n_hubs`` squares, or (None)
    when the next would hold less than ``min_share`` of the points. Returns each
    square with the number of points it holds.

    With ``cover`` each next square is instead the one holding the most points no square
    before holds, and may overlap those (their points stay theirs): the gaps between
    disjoint squares, where a city's orders thin out, are covered too (the whole-export
    run, docs/method.md §1.1). The count returned is then the points it adds."""
    ref, x0, y0, counts, k = _square_grid(lng, lat, size_km, grid_m)
    total = int(counts.sum())
    # The first square is densest_square's; the next may hang over the points' edge
    # (the grid is padded by k - 1 cells), so that squares can tile a whole city.
    # Window (jy, jx) of the padded grid is window (jy - pad, jx - pad) of the points'.
    pad = k - 1
    padded = np.pad(counts, pad)
    taken = np.zeros(padded.shape, dtype=np.int64)  # cells inside a chosen square
    window = _window_sums(padded, k)
    pick = _densest_pick(window, k)
    out: list[tuple[Frame, int]] = []
    while n_hubs is None or len(out) < n_hubs:
        if out and cover:
            window = _window_sums(np.where(taken == 0, padded, 0), k)
            jy, jx = np.unravel_index(int(np.argmax(window)), window.shape)
            pick = (int(jy), int(jx))
        elif out:
            free = _window_sums(taken, k) == 0
            if not free.any():
                break
            score = np.where(free, window, -1)
            jy, jx = np.unravel_index(int(np.argmax(score)), score.shape)
            pick = (int(jy), int(jx))
        held = int(window[pick])
        if held <= 0 or (n_hubs is None and out and held < min_share * total):
            break
        frame = _square_frame(ref, x0, y0, pick[0] - pad, pick[1] - pad, k, grid_m, size_km)
        out.append((frame, held))
        taken[pick[0] : pick[0] + k, pick[1] : pick[1] + k] = 1
    return out
