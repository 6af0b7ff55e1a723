"""Service-area polygons: each depot's Voronoi cell clipped to the study square."""

from __future__ import annotations

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


def _area_geometry(lng: np.ndarray, lat: np.ndarray, center_lng: float) -> dict[str, Any]:
    """A service area's ring as GeoJSON: a Polygon, or, for an area across the
    antimeridian, a MultiPolygon of its parts on either side (RFC 7946 §3.1.9), so no
    ring jumps from 180° to -180° around the globe."""
    unwrapped = center_lng + (lng - center_lng + 180.0) % 360.0 - 180.0
    if unwrapped.max() <= 180.0 and unwrapped.min() >= -180.0:
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
