"""City map of customers, depots and service-area boundaries (like the paper's Fig. 7)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure  # the object API: no pyplot state, no backend chosen

from .areas import area_polygons
from .depots import Depots

if TYPE_CHECKING:
    from .hubs import Hub

# Depots: black squares, apart from every colour the maps use for data (the blue
# customers here, the green-to-red delay scale and the drones' colours of routes.png).
DEPOT_STYLE: dict[str, Any] = {
    "marker": "s",
    "c": "black",
    "edgecolors": "white",
    "linewidths": 0.6,
}
AREA_COLOUR = "#d4a017"


def draw_areas(ax: Axes, depots: Depots, *, labels: bool = True) -> None:
    """Service-area boundaries and depots on ``ax`` (km axes)."""
    for poly in area_polygons(depots):
        if poly:
            arr = np.array(poly + [poly[0]]) / 1000.0
            ax.plot(arr[:, 0], arr[:, 1], color=AREA_COLOUR, lw=1.0, zorder=2)
    ax.scatter(depots.xy[:, 0] / 1000.0, depots.xy[:, 1] / 1000.0, s=36, zorder=4, **DEPOT_STYLE)
    if labels:
        for i, (x, y) in enumerate(depots.xy / 1000.0):
            ax.annotate(str(i), (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
    h = depots.frame.half_m / 1000.0
    ax.set_xlim(-h, h)
    ax.set_ylim(-h, h)
    ax.set_aspect("equal")
    ax.set_xlabel("x (km east of centre)")
    ax.set_ylabel("y (km north of centre)")


def plot_depots(depots: Depots, customers_xy: np.ndarray, path: str | Path, title: str) -> None:
    """Write a PNG map of history customers, depots and service areas."""
    fig = Figure(figsize=(7, 7), dpi=110)
    ax = fig.subplots()
    if customers_xy.size:
        pts = customers_xy
        if pts.shape[0] > 40_000:  # thin the cloud deterministically; the map looks the same
            pts = pts[:: pts.shape[0] // 40_000 + 1]
        ax.scatter(pts[:, 0] / 1000.0, pts[:, 1] / 1000.0, s=1, c="#4a7bb7", alpha=0.25, zorder=1)
    draw_areas(ax, depots)
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, format="png")


HUB_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2")
"""The hubs' outlines, in turn: apart from the customers' blue cloud and the black depots."""


def plot_hubs(
    hubs: Sequence[Hub],
    depots: dict[int, Depots],
    lng: np.ndarray,
    lat: np.ndarray,
    path: str | Path,
    title: str,
) -> None:
    """Write a PNG map of a city's hubs: the history customers (``lng``, ``lat``), each
    hub's square labelled with its id and orders, and its depots (black squares), on km
    axes around the city's centre."""
    from ..data.frame import Frame
    from .hubmap import hub_ring

    rings = [hub_ring(h) for h in hubs]
    all_lng = np.concatenate([r[0] for r in rings])
    all_lat = np.concatenate([r[1] for r in rings])
    # The city's frame: centred between the hubs (the short way round the antimeridian,
    # as Frame.to_xy takes longitudes), so every hub is drawn at its ground scale.
    ref = hubs[0].frame
    x0, y0 = ref.to_xy(all_lng, all_lat)
    c_lng, c_lat = ref.to_lnglat(
        np.array([(x0.min() + x0.max()) / 2]), np.array([(y0.min() + y0.max()) / 2])
    )
    city = Frame(float(c_lng[0]), float(c_lat[0]), ref.size_km)
    fig = Figure(figsize=(8, 8), dpi=110)
    ax = fig.subplots()
    if lng.size:
        x, y = city.to_xy(lng, lat)
        pts = np.column_stack([x, y])
        if pts.shape[0] > 40_000:  # thin the cloud deterministically; the map looks the same
            pts = pts[:: pts.shape[0] // 40_000 + 1]
        ax.scatter(pts[:, 0] / 1000.0, pts[:, 1] / 1000.0, s=1, c="#4a7bb7", alpha=0.2, zorder=1)
    for n, (h, (rlng, rlat)) in enumerate(zip(hubs, rings, strict=True)):
        colour = HUB_COLOURS[n % len(HUB_COLOURS)]
        x, y = city.to_xy(rlng, rlat)
        ax.plot(x / 1000.0, y / 1000.0, color=colour, lw=1.4, zorder=3)
        ax.annotate(
            f"hub {h.id}\n{h.orders:,} orders",
            (x.min() / 1000.0, y.max() / 1000.0),
            textcoords="offset points",
            xytext=(3, -3),
            va="top",
            fontsize=7,
            color=colour,
            zorder=5,
            bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.75},
        )
        if h.id in depots:
            dlng, dlat = depots[h.id].lnglat()
            dx, dy = city.to_xy(dlng, dlat)
            ax.scatter(dx / 1000.0, dy / 1000.0, s=14, zorder=4, **DEPOT_STYLE)
    ax.set_aspect("equal")
    ax.set_xlabel("x (km east of the city's centre)")
    ax.set_ylabel("y (km north of the city's centre)")
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, format="png")
