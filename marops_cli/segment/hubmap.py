"""A city's hubs on a map: each hub's depots as ``replay-day`` segments them in its square,
and the hubs GeoJSON beside a hubs file (docs/outputs.md, "Hubs file")."""

from __future__ import annotations

import datetime as dt
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..config import PlannerConfig
from ..data.jsonfile import first_line
from ..data.table import LadeTable
from ..errors import InputError, naming
from .areas import _area_geometry, _rounded
from .depots import Depots
from .hubs import Hub, hub_owner
from .methods import segment_points

__all__ = ["hub_depots", "hub_ring", "hubs_geojson"]


def hub_depots(
    table: LadeTable, cfg: PlannerConfig, hubs: Sequence[Hub], days: Sequence[dt.date]
) -> tuple[dict[int, Depots], dict[int, str]]:
    """Each hub's depots, segmented (``[segment]``) from the orders it owns
    (:func:`~marops_cli.segment.hubs.hub_owner`) due on ``days``, as ``replay-day``
    segments a hub's over those history days; and, for a hub whose orders cannot be
    segmented (fewer than ``[segment] n_depots``), why, by hub id."""
    owner = hub_owner(table, hubs)
    on = np.isin(table.delivery_day, np.array(list(days), dtype="datetime64[D]"))
    found: dict[int, Depots] = {}
    why: dict[int, str] = {}
    for h in hubs:
        f = h.frame
        mine = on & (owner == h.id)
        x, y = f.to_xy(table.lng[mine], table.lat[mine])
        inside = f.contains(x, y)
        try:
            found[h.id] = segment_points(x[inside], y[inside], f, cfg.segment)
        except InputError as exc:
            why[h.id] = first_line(naming(exc, table.source.path))
    return found, why


def hub_ring(hub: Hub) -> tuple[np.ndarray, np.ndarray]:
    """The hub's square as a closed counter-clockwise ring (longitudes, latitudes)."""
    import shapely

    h = hub.frame.half_m
    square = shapely.orient_polygons(shapely.box(-h, -h, h, h))
    xy = np.asarray(square.exterior.coords)
    return hub.frame.to_lnglat(xy[:, 0], xy[:, 1])


def hubs_geojson(
    hubs: Sequence[Hub], total: int, depots: dict[int, Depots], meta: dict[str, Any]
) -> dict[str, Any]:
    """The hubs GeoJSON (docs/outputs.md, "Hubs file"): per hub its square (a Polygon,
    cut at 180° into a MultiPolygon for a hub across the antimeridian) and then its
    depots (Points), a FeatureCollection whose ``marops`` member is the hubs file's
    ``meta``."""
    features: list[dict[str, Any]] = []
    for h in hubs:
        lng, lat = hub_ring(h)
        props: dict[str, Any] = {
            "kind": "hub",
            "hub": h.id,
            "orders": h.orders,
            "share": h.orders / total if total else 0.0,
            "size_km": h.frame.size_km,
        }
        if h.drones is not None:
            props["drones"] = h.drones
        props["depots"] = len(depots[h.id]) if h.id in depots else 0
        features.append(
            {
                "type": "Feature",
                "properties": props,
                "geometry": _area_geometry(lng, lat, h.frame.center_lng),
            }
        )
        if h.id not in depots:
            continue
        d = depots[h.id]
        dlng, dlat = d.lnglat()
        for i, point in enumerate(_rounded(dlng, dlat)):
            features.append(
                {
                    "type": "Feature",
                    "properties": {
                        "kind": "depot",
                        "hub": h.id,
                        "depot": i,
                        "n_history": int(d.n_history[i]),
                    },
                    "geometry": {"type": "Point", "coordinates": point},
                }
            )
    return {"type": "FeatureCollection", "marops": meta, "features": features}
