"""GeoParquet for the route files (docs/outputs.md, "GeoParquet"): a ``geometry`` column
of WKB (a stop's point, a route's line through its stops) and the ``geo`` metadata of
the GeoParquet 1.1.0 specification, so GIS readers (``geopandas.read_parquet``, QGIS,
DuckDB's spatial extension) take the files as they are."""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pyarrow as pa

from ..segment.areas import line_geometry

GEOMETRY = "geometry"
"""The geometry column: the last of each route file."""
GEO_VERSION = "1.1.0"


def _wkb(geoms: Any) -> pa.Array:
    """Shapely geometries as 2-D ISO WKB, little-endian: the same bytes on every machine."""
    import shapely

    wkb = shapely.to_wkb(geoms, output_dimension=2, byte_order=1, flavor="iso")
    return pa.array(list(wkb), type=pa.binary())


def _geo(types: list[str]) -> str:
    """The ``geo`` metadata of a table whose geometry column holds ``types``. No ``crs``:
    the specification's default, OGC:CRS84 (WGS 84 longitude, latitude: the files'
    ``lng`` and ``lat``)."""
    column = {"encoding": "WKB", "geometry_types": types}
    return json.dumps(
        {"version": GEO_VERSION, "primary_column": GEOMETRY, "columns": {GEOMETRY: column}}
    )


def _with(table: pa.Table, geometry: pa.Array, types: list[str]) -> pa.Table:
    """``table`` with ``geometry`` as its last column and the ``geo`` metadata beside the
    metadata it carries."""
    meta = dict(table.schema.metadata or {})
    meta[b"geo"] = _geo(types).encode("utf-8")
    out = table.append_column(pa.field(GEOMETRY, pa.binary()), geometry)
    return out.replace_schema_metadata(meta)


def geo_route_tables(stops: pa.Table, routes: pa.Table) -> tuple[pa.Table, pa.Table]:
    """(stops, routes) as GeoParquet tables: each stop's point at its ``lng``, ``lat``;
    each route's line through its stops in visiting order (start depot, customers, end
    depot), a MultiLineString cut at 180° for one across the antimeridian, as in
    ``routes.geojson``."""
    import shapely
    from shapely.geometry import shape

    lng = stops.column("lng").to_numpy(zero_copy_only=False)
    lat = stops.column("lat").to_numpy(zero_copy_only=False)
    points = shapely.points(np.column_stack([lng, lat])) if len(lng) else np.array([])
    path: dict[tuple[Any, ...], list[tuple[int, float, float]]] = {}
    for r in stops.select(["hub", "day", "window", "drone", "seq", "lng", "lat"]).to_pylist():
        key = (r["hub"], r["day"], r["window"], r["drone"])
        path.setdefault(key, []).append((r["seq"], r["lng"], r["lat"]))
    lines = []
    for r in routes.select(["hub", "day", "window", "drone"]).to_pylist():
        nodes = sorted(path[(r["hub"], r["day"], r["window"], r["drone"])])
        geom = line_geometry([n[1] for n in nodes], [n[2] for n in nodes])
        lines.append(shape(geom))
    line_types = sorted({g.geom_type for g in lines})
    return (
        _with(stops, _wkb(points), ["Point"]),
        _with(routes, _wkb(np.array(lines, dtype=object)), line_types),
    )
