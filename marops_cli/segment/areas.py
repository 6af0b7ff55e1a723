"""Service-area polygons: each depot's Voronoi cell clipped to the study square."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .depots import Depots


def area_polygons(depots: Depots) -> list[list[tuple[float, float]]]:
    """Polygon (metres, counter-clockwise, open ring) of each depot's service area: its
    Voronoi cell (shapely, GEOS) clipped to the study square."""
    import shapely  # loads with the first map or GeoJSON, not with the CLI

    h = depots.frame.half_m
    square = shapely.box(-h, -h, h, h)
    if len(depots) == 1:
        cells = [square]
    else:
        points = shapely.multipoints(np.asarray(depots.xy, dtype=np.float64))
        # ordered: cell i belongs to depot i (GEOS >= 3.12); extent: cells reach the square.
        voronoi = shapely.voronoi_polygons(points, extend_to=square, ordered=True)
        cells = [square.intersection(c) for c in shapely.get_parts(voronoi)]
    return [_ring(cell) for cell in cells]


def _ring(cell: Any) -> list[tuple[float, float]]:
    """A cell's outline as an open, counter-clockwise ring (empty for an empty cell)."""
    import shapely

    if cell.is_empty or cell.geom_type != "Polygon":
        return []
    coords = shapely.orient_polygons(cell).exterior.coords
    return [(float(x), float(y)) for x, y in list(coords)[:-1]]


def _rounded(lng: Any, lat: Any) -> list[list[float]]:
    return [[round(float(a), 7), round(float(b), 7)] for a, b in zip(lng, lat, strict=True)]


def _unwrapped(lng: np.ndarray, ref_lng: float) -> np.ndarray:
    """Longitudes as one continuous run around ``ref_lng``: a place just across the
    antimeridian from it reads beyond 180° (or below -180°) instead of round the globe."""
    return ref_lng + (lng - ref_lng + 180.0) % 360.0 - 180.0


def _crosses(unwrapped: np.ndarray) -> bool:
    return bool(unwrapped.max() > 180.0 or unwrapped.min() < -180.0)


def _area_geometry(lng: np.ndarray, lat: np.ndarray, center_lng: float) -> dict[str, Any]:
    """A service area's ring as GeoJSON: a Polygon, or, for an area across the
    antimeridian, a MultiPolygon of its parts on either side (RFC 7946 §3.1.9), so no
    ring jumps from 180° to -180° around the globe."""
    unwrapped = _unwrapped(lng, center_lng)
    if not _crosses(unwrapped):
        return {"type": "Polygon", "coordinates": [_rounded(lng, lat)]}
    import shapely

    whole = shapely.Polygon(np.column_stack([unwrapped, lat]))
    parts = []
    for shift in (-360.0, 0.0, 360.0):
        piece = whole.intersection(shapely.box(-180.0 - shift, -90.0, 180.0 - shift, 90.0))
        for part in shapely.get_parts(piece):
            if part.geom_type == "Polygon" and not part.is_empty:
                xy = np.asarray(shapely.orient_polygons(part).exterior.coords)
                parts.append([_rounded(xy[:, 0] + shift, xy[:, 1])])
    return {"type": "MultiPolygon", "coordinates": parts}


def line_geometry(lng: Sequence[float], lat: Sequence[float]) -> dict[str, Any]:
    """A path through ``(lng, lat)`` in order as GeoJSON: a LineString of the positions
    as they are, or, for a path across the antimeridian, a MultiLineString of its parts
    on either side, in the path's order, each cut at 180° (RFC 7946 §3.1.9) where the
    leg that crosses meets it, so no leg jumps from 180° to -180° around the globe."""
    x = np.asarray(lng, dtype=np.float64)
    y = np.asarray(lat, dtype=np.float64)
    unwrapped = _unwrapped(x, float(x[0])) if x.size else x
    if not x.size or not _crosses(unwrapped):
        coords = [[a, b] for a, b in zip(lng, lat, strict=True)]
        return {"type": "LineString", "coordinates": coords}
    sheet = np.floor((unwrapped + 180.0) / 360.0)  # which copy of -180..180 a position is on
    parts: list[list[list[float]]] = [[[float(x[0]), float(y[0])]]]
    for i in range(1, x.size):
        if sheet[i] != sheet[i - 1]:  # this leg crosses 180° (a leg is far shorter than 360°)
            east = sheet[i] > sheet[i - 1]
            edge = 180.0 + 360.0 * float(min(sheet[i], sheet[i - 1]))
            t = (edge - unwrapped[i - 1]) / (unwrapped[i] - unwrapped[i - 1])
            at = float(y[i - 1] + t * (y[i] - y[i - 1]))
            parts[-1].append([180.0 if east else -180.0, at])
            parts.append([[-180.0 if east else 180.0, at]])
        parts[-1].append([float(x[i]), float(y[i])])
    lines = [p for p in parts if any(q != p[0] for q in p)]  # no part of one position
    if len(lines) == 1:  # a path that only touches 180°
        return {"type": "LineString", "coordinates": lines[0]}
    return {"type": "MultiLineString", "coordinates": lines}


def areas_geojson(depots: Depots, meta: dict[str, Any]) -> dict[str, Any]:
    """A GeoJSON FeatureCollection of depots (points) and service areas (polygons)."""
    features: list[dict[str, Any]] = []
    lng, lat = depots.lnglat()
    for i, poly in enumerate(area_polygons(depots)):
        if poly:
            arr = np.array(poly + [poly[0]])
            plng, plat = depots.frame.to_lnglat(arr[:, 0], arr[:, 1])
            features.append(
                {
                    "type": "Feature",
                    "properties": {"kind": "service_area", "depot": i},
                    "geometry": _area_geometry(plng, plat, depots.frame.center_lng),
                }
            )
        features.append(
            {
                "type": "Feature",
                "properties": {
                    "kind": "depot",
                    "depot": i,
                    "n_history": int(depots.n_history[i]),
                    "candidates": [int(c) for c in depots.candidates[i]],
                },
                "geometry": {
                    "type": "Point",
                    "coordinates": [round(float(lng[i]), 7), round(float(lat[i]), 7)],
                },
            }
        )
    return {"type": "FeatureCollection", "marops": meta, "features": features}
