"""Stops and routes tables of docs/outputs.md, built from planned windows."""

from __future__ import annotations

import datetime as dt
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any
from zoneinfo import ZoneInfo

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from ..data.arrow import native_file
from ..data.table import DayRequests
from ..energy import EnergyModel
from ..plans.window import WindowPlan
from ..segment.areas import line_geometry
from ..segment.depots import Depots
from .geoparquet import geo_route_tables

DEFAULT_TZ = "Asia/Shanghai"  # LaDe's times are Shanghai local time


# The columns that open both tables: the hub, day, window and drone a row belongs to.
_KEY_COLUMNS = ("hub", "day", "window", "window_start", "drone")


def _key_fields(tz: str) -> list[tuple[str, pa.DataType]]:
    """The types of :data:`_KEY_COLUMNS`; timestamps local to zone ``tz``."""
    types = (pa.int32(), pa.date32(), pa.int32(), pa.timestamp("s", tz=tz), pa.int32())
    return list(zip(_KEY_COLUMNS, types, strict=True))


def stops_schema(tz: str = DEFAULT_TZ) -> pa.Schema:
    """The stops table (docs/outputs.md); timestamps are local times of zone ``tz``."""
    return pa.schema(
        [
            *_key_fields(tz),
            ("seq", pa.int32()),
            ("kind", pa.string()),
            ("depot", pa.int32()),
            ("order_id", pa.string()),
            ("x_m", pa.float64()),
            ("y_m", pa.float64()),
            ("lng", pa.float64()),
            ("lat", pa.float64()),
            ("arrive_s", pa.float64()),
            ("arrive_time", pa.timestamp("s", tz=tz)),
            ("leg_m", pa.float64()),
            ("leg_j", pa.float64()),
            ("payload_kg", pa.float64()),
            ("weight_kg", pa.float64()),
            ("due_window", pa.int32()),
            ("delay_h", pa.float64()),
            ("method", pa.string()),
        ]
    )


def routes_schema(tz: str = DEFAULT_TZ) -> pa.Schema:
    """The routes table (docs/outputs.md)."""
    return pa.schema(
        [
            *_key_fields(tz),
            ("drone_type", pa.string()),
            ("start_depot", pa.int32()),
            ("end_depot", pa.int32()),
            ("n_parcels", pa.int32()),
            ("payload_kg", pa.float64()),
            ("distance_m", pa.float64()),
            ("energy_j", pa.float64()),
            ("battery_frac", pa.float64()),
            ("action", pa.int32()),
            ("method", pa.string()),
        ]
    )


STOPS_SCHEMA = stops_schema()
ROUTES_SCHEMA = routes_schema()


def build_tables(
    day: DayRequests,
    depots: Depots,
    plans: Sequence[WindowPlan],
    model: EnergyModel,
    method: str,
    tz: str = DEFAULT_TZ,
    drone_models: Sequence[EnergyModel] | None = None,
    drone_types: Sequence[str] | None = None,
    hub: int = 0,
) -> tuple[pa.Table, pa.Table]:
    """(stops, routes) for the given windows of one day; times are local to ``tz``.

    ``drone_models`` and ``drone_types`` give each drone's type (speed and battery,
    and its name); None: every drone is ``model``'s, the type ``default``. ``hub`` is
    the study area's hub id (0 for a single study area).
    """
    s_schema, r_schema = stops_schema(tz), routes_schema(tz)
    stops: dict[str, list[Any]] = {f.name: [] for f in s_schema}
    routes: dict[str, list[Any]] = {f.name: [] for f in r_schema}
    dlng, dlat = depots.lnglat()
    zone = ZoneInfo(tz)
    day_s = day.day
    for plan in plans:
        ws = day.window_instant(plan.t).astimezone(zone)
        for r in plan.routes:
            key = (hub, day_s, plan.t, ws, r.drone)
            n = len(r.stops)
            nodes = [("start", r.start, None)] + [("customer", None, i) for i in r.stops]
            nodes.append(("end", r.end, None))
            leg_m = np.concatenate([[0.0], r.legs_m])
            leg_j = np.concatenate([[0.0], r.legs_j])
            own = model if drone_models is None else drone_models[r.drone]
            arrive = np.cumsum(leg_m) / own.speed_ms
            w = day.weight_kg[list(r.stops)] if n else np.zeros(0)
            # Parcels on board when leaving each node (eq. 6): all at the start, none at the end.
            on_board = np.concatenate([np.cumsum(w[::-1])[::-1], [0.0]]) if n else np.zeros(1)
            on_board = np.append(on_board, 0.0)
            for seq, (kind, dep, i) in enumerate(nodes):
                _append(stops, key)
                stops["seq"].append(seq)
                stops["kind"].append(kind)
                stops["depot"].append(dep)
                if i is None:
                    stops["order_id"].append(None)
                    stops["x_m"].append(float(depots.xy[dep, 0]))
                    stops["y_m"].append(float(depots.xy[dep, 1]))
                    stops["lng"].append(float(dlng[dep]))
                    stops["lat"].append(float(dlat[dep]))
                    stops["weight_kg"].append(None)
                    stops["due_window"].append(None)
                    stops["delay_h"].append(None)
                else:
                    stops["order_id"].append(str(day.order_id[i]))
                    stops["x_m"].append(float(day.x_m[i]))
                    stops["y_m"].append(float(day.y_m[i]))
                    stops["lng"].append(float(day.lng[i]))
                    stops["lat"].append(float(day.lat[i]))
                    stops["weight_kg"].append(float(day.weight_kg[i]))
                    stops["due_window"].append(int(day.due_w[i]))
                    stops["delay_h"].append(max(0, plan.t - int(day.due_w[i])) * day.window_hours)
                stops["arrive_s"].append(float(arrive[seq]))
                # whole seconds, like window_start (arrive_s keeps the fraction)
                # elapsed time: ws + a timedelta would add it to the wall clock
                stops["arrive_time"].append(
                    (ws.astimezone(dt.UTC) + dt.timedelta(seconds=int(arrive[seq]))).astimezone(
                        zone
                    )
                )
                stops["leg_m"].append(float(leg_m[seq]))
                stops["leg_j"].append(float(leg_j[seq]))
                stops["payload_kg"].append(float(on_board[seq]))
                stops["method"].append(method)
            _append(routes, key)
            routes["drone_type"].append("default" if drone_types is None else drone_types[r.drone])
            routes["start_depot"].append(r.start)
            routes["end_depot"].append(r.end)
            routes["n_parcels"].append(n)
            routes["payload_kg"].append(r.payload_kg)
            routes["distance_m"].append(r.distance_m)
            routes["energy_j"].append(r.energy_j)
            routes["battery_frac"].append(r.energy_j / own.cfg.battery_j)
            routes["action"].append(r.action)
            routes["method"].append(method)
    return (
        pa.Table.from_pydict(stops, schema=s_schema),
        pa.Table.from_pydict(routes, schema=r_schema),
    )


def _append(columns: dict[str, list[Any]], key: tuple[Any, ...]) -> None:
    """A row's :data:`_KEY_COLUMNS` values onto the columns being built."""
    for name, value in zip(_KEY_COLUMNS, key, strict=True):
        columns[name].append(value)


def with_meta(table: pa.Table, meta: dict[str, Any]) -> pa.Table:
    """``table`` with the run's metadata under ``marops`` (and the pandas types of its
    nullable integer columns, :func:`pandas_metadata`)."""
    head = {"marops": json.dumps(meta, sort_keys=False)}
    pandas = pandas_metadata(table)
    if pandas is not None:
        head["pandas"] = pandas
    return table.replace_schema_metadata(head)


def pandas_metadata(table: pa.Table) -> str | None:
    """pandas reads an integer column holding a missing value as float64 (a stop's
    ``depot`` and ``due_window``); the pandas metadata pyarrow reads back names the
    nullable type instead (``Int32``), so ``pd.read_parquet`` and ``to_pandas`` give
    integers with ``<NA>``. Columns without a missing value keep their numpy type;
    None when no column needs it. polars and DuckDB read the Parquet types alone."""
    columns = [
        {
            "name": f.name,
            "field_name": f.name,
            "pandas_type": str(f.type),
            "numpy_type": f"{'U' if pa.types.is_unsigned_integer(f.type) else ''}Int"
            f"{f.type.bit_width}",
            "metadata": None,
        }
        for f, col in zip(table.schema, table.columns, strict=True)
        if pa.types.is_integer(f.type) and col.null_count > 0
    ]
    if not columns:
        return None
    return json.dumps({"index_columns": [], "column_indexes": [], "columns": columns})


def write_parquet(table: pa.Table, path: str | Path) -> None:
    """Deterministic Parquet: no statistics that vary, fixed compression."""
    with native_file(path, "w") as sink:  # a folder name that is not UTF-8 included
        pq.write_table(table, sink, compression="zstd", write_statistics=True)


def write_csv(table: pa.Table, path: str | Path) -> None:
    """``table`` as CSV (pyarrow's writer), in a folder of any name."""
    import pyarrow.csv as pacsv

    with native_file(path, "w") as sink:
        pacsv.write_csv(table, sink)


def table_records(table: pa.Table) -> list[dict[str, Any]]:
    """JSON-ready rows (timestamps and dates as ISO text, with the zone's offset)."""
    rows = table.to_pylist()
    zones = {
        f.name: ZoneInfo(f.type.tz)
        for f in table.schema
        if pa.types.is_timestamp(f.type) and f.type.tz is not None
    }
    for row in rows:
        for k, v in row.items():
            if isinstance(v, dt.datetime):
                row[k] = (v.astimezone(zones[k]) if k in zones else v).isoformat()
            elif isinstance(v, dt.date):
                row[k] = v.isoformat()
    return rows


def routes_geojson(stops: pa.Table, routes: pa.Table, meta: dict[str, Any]) -> dict[str, Any]:
    """A GeoJSON FeatureCollection: one LineString per route in lng/lat (start depot,
    customers, end depot; a MultiLineString cut at 180° for a route across the
    antimeridian) with the route's columns as properties (docs/outputs.md)."""
    st = stops.select(["day", "window", "drone", "seq", "lng", "lat"]).to_pylist()
    path: dict[tuple[Any, int, int], list[tuple[int, list[float]]]] = {}
    for r in st:
        path.setdefault((r["day"], r["window"], r["drone"]), []).append(
            (r["seq"], [r["lng"], r["lat"]])
        )
    features = []
    for props in table_records(routes):
        key = (dt.date.fromisoformat(props["day"]), props["window"], props["drone"])
        coords = [c for _, c in sorted(path[key])]
        features.append(
            {
                "type": "Feature",
                "geometry": line_geometry([c[0] for c in coords], [c[1] for c in coords]),
                "properties": props,
            }
        )
    return {"type": "FeatureCollection", "marops": meta, "features": features}


def write_route_files(
    files: Any,
    folder: Path,
    stops: pa.Table,
    routes: pa.Table,
    meta: dict[str, Any],
    fmt: str = "parquet",
    geojson: bool = False,
) -> list[Path]:
    """``folder/stops.parquet`` and ``folder/routes.parquet`` (``fmt = "json"``:
    ``stops.json`` and ``routes.json`` with the metadata under ``meta``), and with
    ``geojson`` ``folder/routes.geojson``. The Parquet files are GeoParquet: a
    ``geometry`` column and the ``geo`` metadata (:mod:`marops_cli.io.geoparquet`).
    Returns the paths written."""
    paths = route_file_paths(folder, fmt, geojson)
    if fmt == "parquet":
        geo = geo_route_tables(with_meta(stops, meta), with_meta(routes, meta))
        files.write_with(paths[0], lambda p: write_parquet(geo[0], p))
        files.write_with(paths[1], lambda p: write_parquet(geo[1], p))
    else:
        files.write_json(paths[0], {"meta": meta, "stops": table_records(stops)})
        files.write_json(paths[1], {"meta": meta, "routes": table_records(routes)})
    if geojson:
        files.write_json(paths[-1], routes_geojson(stops, routes, meta))
    return paths


def route_file_paths(folder: Path, fmt: str = "parquet", geojson: bool = False) -> list[Path]:
    """The files :func:`write_route_files` writes: stops, routes (and routes.geojson)."""
    if fmt not in ("parquet", "json"):
        raise ValueError(f"expected format parquet or json, got {fmt!r}")
    paths = [folder / f"stops.{fmt}", folder / f"routes.{fmt}"]
    return paths + [folder / "routes.geojson"] if geojson else paths
