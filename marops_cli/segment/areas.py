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


def areas_geojson(depots: Depots, meta: dict[str, Any]) -> dict[str, Any]:
    """A GeoJSON FeatureCollection of depots (points) and service areas (polygons)."""
    features: list[dict[str, Any]] = []
    lng, lat = depots.lnglat()
    for i, poly in enumerate(area_polygons(depots)):
        if poly:
            arr = np.array(poly + [poly[0]])
            plng, plat = depots.frame.to_lnglat(arr[:, 0], arr[:, 1])
            ring = [
                [round(float(a), 7), round(float(b), 7)] for a, b in zip(plng, plat, strict=True)
            ]
            features.append(
                {
                    "type": "Feature",
                    "properties": {"kind": "service_area", "depot": i},
                    "geometry": {"type": "Polygon", "coordinates": [ring]},
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
