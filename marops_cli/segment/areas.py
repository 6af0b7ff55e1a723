"""Service-area polygons: each depot's Voronoi cell clipped to the study square."""

from __future__ import annotations

from typing import Any

import numpy as np

from .depots import Depots


def _clip(poly: list[tuple[float, float]], a: np.ndarray, b: float) -> list[tuple[float, float]]:
    """Keep the part of ``poly`` where a·p <= b (Sutherland-Hodgman, one half-plane)."""
    out: list[tuple[float, float]] = []
    n = len(poly)
    for i in range(n):
        p, q = np.array(poly[i]), np.array(poly[(i + 1) % n])
        fp, fq = float(a @ p - b), float(a @ q - b)
        if fp <= 0:
            out.append((float(p[0]), float(p[1])))
        if (fp < 0 < fq) or (fq < 0 < fp):
            t = fp / (fp - fq)
            r = p + t * (q - p)
            out.append((float(r[0]), float(r[1])))
    return out


def area_polygons(depots: Depots) -> list[list[tuple[float, float]]]:
    """Polygon (metres, counter-clockwise, open ring) of each depot's service area."""
    h = depots.frame.half_m
    square = [(-h, -h), (h, -h), (h, h), (-h, h)]
    polys = []
    for i in range(len(depots)):
        poly = square
        pi = depots.xy[i]
        for j in range(len(depots)):
            if j == i or not poly:
                continue
            pj = depots.xy[j]
            # Points nearer to i than to j: (pj - pi)·p <= (|pj|² - |pi|²) / 2.
            a = pj - pi
            b = float((pj @ pj - pi @ pi) / 2.0)
            poly = _clip(poly, a, b)
        polys.append(poly)
    return polys


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
