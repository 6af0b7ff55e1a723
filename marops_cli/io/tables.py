"""Stops and routes tables of docs/outputs.md, built from planned windows."""

from __future__ import annotations

import datetime as dt
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from ..data.table import DayRequests
from ..energy import EnergyModel
from ..plans.window import WindowPlan
from ..segment.depots import Depots

STOPS_SCHEMA = pa.schema(
    [
        ("day", pa.string()),
        ("window", pa.int32()),
        ("window_start", pa.timestamp("s")),
        ("drone", pa.int32()),
        ("seq", pa.int32()),
        ("kind", pa.string()),
        ("depot", pa.int32()),
        ("order_id", pa.string()),
        ("x_m", pa.float64()),
        ("y_m", pa.float64()),
        ("lng", pa.float64()),
        ("lat", pa.float64()),
        ("arrive_s", pa.float64()),
        ("leg_m", pa.float64()),
        ("leg_j", pa.float64()),
        ("payload_kg", pa.float64()),
        ("weight_kg", pa.float64()),
        ("due_window", pa.int32()),
        ("delay_h", pa.float64()),
        ("method", pa.string()),
    ]
)

ROUTES_SCHEMA = pa.schema(
    [
        ("day", pa.string()),
        ("window", pa.int32()),
        ("window_start", pa.timestamp("s")),
        ("drone", pa.int32()),
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


def build_tables(
    day: DayRequests,
    depots: Depots,
    plans: Sequence[WindowPlan],
    model: EnergyModel,
    method: str,
) -> tuple[pa.Table, pa.Table]:
    """(stops, routes) for the given windows of one day."""
    stops: dict[str, list[Any]] = {f.name: [] for f in STOPS_SCHEMA}
    routes: dict[str, list[Any]] = {f.name: [] for f in ROUTES_SCHEMA}
    dlng, dlat = depots.lnglat()
    day_s = day.day.isoformat()
    for plan in plans:
        ws = day.window_start(plan.t)
        for r in plan.routes:
            n = len(r.stops)
            nodes = [("start", r.start, None)] + [("customer", None, i) for i in r.stops]
            nodes.append(("end", r.end, None))
            leg_m = np.concatenate([[0.0], r.legs_m])
            leg_j = np.concatenate([[0.0], r.legs_j])
            arrive = np.cumsum(leg_m) / model.speed_ms
            w = day.weight_kg[list(r.stops)] if n else np.zeros(0)
            # Parcels on board when leaving each node (eq. 6): all at the start, none at the end.
            on_board = np.concatenate([np.cumsum(w[::-1])[::-1], [0.0]]) if n else np.zeros(1)
            on_board = np.append(on_board, 0.0)
            for seq, (kind, dep, i) in enumerate(nodes):
                stops["day"].append(day_s)
                stops["window"].append(plan.t)
                stops["window_start"].append(ws)
                stops["drone"].append(r.drone)
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
                stops["leg_m"].append(float(leg_m[seq]))
                stops["leg_j"].append(float(leg_j[seq]))
                stops["payload_kg"].append(float(on_board[seq]))
                stops["method"].append(method)
            routes["day"].append(day_s)
            routes["window"].append(plan.t)
            routes["window_start"].append(ws)
            routes["drone"].append(r.drone)
            routes["start_depot"].append(r.start)
            routes["end_depot"].append(r.end)
            routes["n_parcels"].append(n)
            routes["payload_kg"].append(r.payload_kg)
            routes["distance_m"].append(r.distance_m)
            routes["energy_j"].append(r.energy_j)
            routes["battery_frac"].append(r.energy_j / model.cfg.battery_j)
            routes["action"].append(r.action)
            routes["method"].append(method)
    return (
        pa.Table.from_pydict(stops, schema=STOPS_SCHEMA),
        pa.Table.from_pydict(routes, schema=ROUTES_SCHEMA),
    )


def with_meta(table: pa.Table, meta: dict[str, Any]) -> pa.Table:
    return table.replace_schema_metadata({"marops": json.dumps(meta, sort_keys=False)})


def write_parquet(table: pa.Table, path: str | Path) -> None:
    """Deterministic Parquet: no statistics that vary, fixed compression."""
    pq.write_table(table, str(path), compression="zstd", write_statistics=True)


def table_records(table: pa.Table) -> list[dict[str, Any]]:
    """JSON-ready rows (timestamps as ISO strings)."""
    rows = table.to_pylist()
    for row in rows:
        for k, v in row.items():
            if isinstance(v, dt.datetime):
                row[k] = v.isoformat()
    return rows


def write_route_files(
    files: Any, out: Path, stops: pa.Table, routes: pa.Table, meta: dict[str, Any]
) -> list[Path]:
    """``X.parquet`` (stops) + ``X.routes.parquet``, or one ``X.json`` with meta/stops/routes."""
    if out.suffix == ".json":
        files.write_json(
            out, {"meta": meta, "stops": table_records(stops), "routes": table_records(routes)}
        )
        return [out]
    if out.suffix != ".parquet":
        raise ValueError(f"expected --out to end in .parquet or .json, got {out.name}")
    routes_path = out.with_name(out.name.removesuffix(".parquet") + ".routes.parquet")
    files.write_with(out, lambda p: write_parquet(with_meta(stops, meta), p))
    files.write_with(routes_path, lambda p: write_parquet(with_meta(routes, meta), p))
    return [out, routes_path]
