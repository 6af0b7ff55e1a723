"""The map's ground: web-map tiles of the study square where the browser is online, and
the service areas drawn as a plain basemap under them, which is all an offline page
shows (docs/report.md)."""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from ..data.frame import Frame

TILE_URL = (
    "https://server.arcgisonline.com/ArcGIS/rest/services/Canvas/World_Light_Gray_Base/"
    "MapServer/tile/{z}/{y}/{x}"
)
"""Esri's light grey canvas: raster tiles that need no key and no referrer (a page opened
from a file sends none), quiet enough for the routes to stand out."""
TILE_HOST = "https://server.arcgisonline.com/"
TILES_ENV = "MAROPS_TILES"
"""``off``: pages draw no tiles and may fetch nothing at all (the study area's location
never leaves the machine); unset or ``on``: the tiles under the map."""
ATTRIBUTION = "Tiles © Esri — Esri, DeLorme, NAVTEQ"
_MAX_ZOOM = 16  # the canvas's deepest tiles
_MAX_TILES_ACROSS = 4


def tiles_on() -> bool:
    """Whether pages draw the map's tiles (:data:`TILES_ENV`, docs/report.md)."""
    from ..errors import InputError

    value = os.environ.get(TILES_ENV, "").strip().lower()
    if value in ("", "on", "1", "true", "yes"):
        return True
    if value in ("off", "0", "false", "no"):
        return False
    raise InputError(f"{TILES_ENV} expects on or off, got {value!r}")


def extent(frame: Frame) -> tuple[float, float, float, float]:
    """(west, south, east, north) of the study square, degrees."""
    h = frame.half_m
    (west, east), (south, north) = frame.to_lnglat(np.array([-h, h]), np.array([-h, h]))
    return float(west), float(south), float(east), float(north)


def _tile(lng: float, lat: float, z: int) -> tuple[int, int]:
    n = 2**z
    x = int((lng + 180.0) / 360.0 * n)
    r = math.radians(lat)
    y = int((1.0 - math.asinh(math.tan(r)) / math.pi) / 2.0 * n)
    return x, y


def _corner(x: int, y: int, z: int) -> tuple[float, float]:
    """(lng, lat) of a tile's north-west corner."""
    n = 2**z
    lat = math.degrees(math.atan(math.sinh(math.pi * (1.0 - 2.0 * y / n))))
    return x / n * 360.0 - 180.0, lat


def tile_images(frame: Frame) -> list[dict[str, Any]]:
    """plotly layout images: the tiles covering the square at the finest zoom that needs
    at most four across, each stretched over its longitude and latitude span (a tile's
    Mercator rows are close to linear in latitude over a few kilometres)."""
    west, south, east, north = extent(frame)
    z = _MAX_ZOOM
    while z > 1:
        x0, y0 = _tile(west, north, z)
        x1, y1 = _tile(east, south, z)
        if x1 - x0 < _MAX_TILES_ACROSS and y1 - y0 < _MAX_TILES_ACROSS:
            break
        z -= 1
    images = []
    for x in range(x0, x1 + 1):
        for y in range(y0, y1 + 1):
            lng0, lat0 = _corner(x, y, z)
            lng1, lat1 = _corner(x + 1, y + 1, z)
            images.append(
                {
                    "source": TILE_URL.format(z=z, x=x, y=y),
                    "xref": "x",
                    "yref": "y",
                    "x": lng0,
                    "y": lat0,
                    "sizex": lng1 - lng0,
                    "sizey": lat0 - lat1,
                    "xanchor": "left",
                    "yanchor": "top",
                    "sizing": "stretch",
                    "layer": "below",
                    "opacity": 0.9,
                }
            )
    return images
