"""Depots, service areas and action candidates (docs/method.md §2)."""

from .areas import area_polygons, areas_geojson, line_geometry
from .depots import Depots, nearest_candidates
from .methods import kmeans_depots, segment_points, squares_depots

__all__ = [
    "Depots",
    "area_polygons",
    "areas_geojson",
    "kmeans_depots",
    "line_geometry",
    "nearest_candidates",
    "segment_points",
    "squares_depots",
]
