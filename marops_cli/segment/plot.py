"""City map of customers, depots and service-area boundaries (like the paper's Fig. 7)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure  # the object API: no pyplot state, no backend chosen

from .areas import area_polygons
from .depots import Depots

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
