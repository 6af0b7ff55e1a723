"""Stops and routes tables (docs/outputs.md) from a hand-made window, and their writers."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path
from zoneinfo import ZoneInfo

import numpy as np
import pyarrow.parquet as pq
import pytest
from numpy.testing import assert_allclose

from marops_cli.data.frame import Frame
from marops_cli.data.table import DayRequests
from marops_cli.energy import EnergyModel
from marops_cli.io import output_set
from marops_cli.io.tables import (
    ROUTES_SCHEMA,
    STOPS_SCHEMA,
    build_tables,
    routes_geojson,
    table_records,
    write_route_files,
)
from marops_cli.plans.select import SelectionResult
from marops_cli.plans.window import DroneRoute, WindowPlan
from marops_cli.segment.depots import Depots, nearest_candidates

FRAME = Frame(121.47, 31.23, 10.0)
DEPOT_XY = np.array([[0.0, 0.0], [2000.0, 0.0]])
ORDER_XY = np.array([[0, 1000], [2000, 1000], [750, 1000], [-750, 0], [500, -1000]], float)
WEIGHT = np.array([2.0, 1.5, 1.0, 0.5, 1.0])
DUE_W = np.array([1, 2, 2, 0, 5], dtype=np.int32)
T = 4
SHANGHAI = ZoneInfo("Asia/Shanghai")


@pytest.fixture(scope="module")
def model() -> EnergyModel:
    return EnergyModel()


@pytest.fixture(scope="module")
def depots() -> Depots:
    return Depots("kmeans", FRAME, DEPOT_XY, np.array([3, 2]), nearest_candidates(DEPOT_XY, 2))


@pytest.fixture(scope="module")
def day() -> DayRequests:
    lng, lat = FRAME.to_lnglat(ORDER_XY[:, 0], ORDER_XY[:, 1])
    return DayRequests(
        day=dt.date(2022, 8, 11),
        frame=FRAME,
        service_start_s=9 * 3600,
        window_s=1800.0,
        n_windows=16,
        order_id=np.array(["o40", "o41", "o42", "o43", "o44"], dtype=object),
        x_m=ORDER_XY[:, 0],
        y_m=ORDER_XY[:, 1],
        lng=lng,
        lat=lat,
        weight_kg=WEIGHT,
        visible_w=np.zeros(5, dtype=np.int32),
        due_w=DUE_W,
        due_s=DUE_W * 1800.0 + 900.0,
        accept_s=np.zeros(5),
    )


@pytest.fixture(scope="module")
def plan(model) -> WindowPlan:
    """Drone 0: depot 0 -> order 0 (2.0 kg) -> order 3 (0.5 kg) -> depot 0.
    Drone 1 stays at depot 1 with nothing to carry."""
    legs_m = np.array([1000.0, 1250.0, 750.0])
    legs_j = model.leg_energy_j(legs_m, [2.5, 0.5, 0.0])
    routes = [
        DroneRoute(0, 0, 0, 0, (0, 3), legs_m, legs_j, 2.5),
        DroneRoute(1, 1, 1, 0, (), np.zeros(1), np.zeros(1), 0.0),
    ]
    sel = SelectionResult(np.array([3, 0]), 1.0, "optimal", False, 0.0, 0.0)
    return WindowPlan(T, routes, sel, n_candidates=5)


@pytest.fixture(scope="module")
def tables(day, depots, plan, model):
    return build_tables(day, depots, [plan], model, "marops")


def test_schemas_are_the_documented_ones(tables):
    stops, routes = tables
    assert stops.schema.equals(STOPS_SCHEMA) and routes.schema.equals(ROUTES_SCHEMA)
    assert stops.schema.names[:9] == [
        "hub",
        "day",
        "window",
        "window_start",
        "drone",
        "seq",
        "kind",
        "depot",
        "order_id",
    ]
    # local times of the data's zone (LaDe: Shanghai), whole seconds
    assert str(stops.schema.field("window_start").type) == "timestamp[s, tz=Asia/Shanghai]"
    assert str(stops.schema.field("arrive_time").type) == "timestamp[s, tz=Asia/Shanghai]"
    assert str(stops.schema.field("day").type) == "date32[day]"


def test_stops_hand_values(tables, model):
    st = tables[0].to_pydict()
    assert st["hub"] == [0] * 6 and tables[1].column("hub").to_pylist() == [0, 0]
    assert st["drone"] == [0, 0, 0, 0, 1, 1]
    assert st["seq"] == [0, 1, 2, 3, 0, 1]
    assert st["kind"] == ["start", "customer", "customer", "end", "start", "end"]
    assert st["depot"] == [0, None, None, 0, 1, 1]
    assert st["order_id"] == [None, "o40", "o43", None, None, None]
    assert set(st["day"]) == {dt.date(2022, 8, 11)} and set(st["window"]) == {T}
    ws = dt.datetime(2022, 8, 11, 11, 0, tzinfo=SHANGHAI)  # 09:00 + 4 × 30 min, local
    assert set(st["window_start"]) == {ws}
    assert ws == dt.datetime(2022, 8, 11, 3, 0, tzinfo=dt.UTC)
    assert st["x_m"] == [0.0, 0.0, -750.0, 0.0, 2000.0, 2000.0]
    assert st["y_m"] == [0.0, 1000.0, 0.0, 0.0, 0.0, 0.0]
    lng, lat = FRAME.to_lnglat(np.array([0.0, 2000.0]), np.zeros(2))
    assert st["lng"][0] == lng[0] and st["lat"][5] == lat[1]
    # 10 m/s: 1000 m -> 100 s, +1250 m -> 225 s, +750 m -> 300 s
    assert_allclose(st["arrive_s"], [0, 100, 225, 300, 0, 0])
    assert st["arrive_time"] == [ws + dt.timedelta(seconds=s) for s in (0, 100, 225, 300, 0, 0)]
    assert_allclose(st["leg_m"], [0, 1000, 1250, 750, 0, 0])
    assert_allclose(
        st["leg_j"][1:4], [1000 * 29.426, 1250 * 18.091, 750 * 15.991], rtol=1e-4
    )  # docs/method.md §3 kJ/km at 2.5, 0.5, 0 kg
    # parcels on board when leaving each node (eq. 6)
    assert_allclose(st["payload_kg"], [2.5, 0.5, 0.0, 0.0, 0.0, 0.0])
    assert st["weight_kg"] == [None, 2.0, 0.5, None, None, None]
    assert st["due_window"] == [None, 1, 0, None, None, None]
    assert st["delay_h"] == [None, 1.5, 2.0, None, None, None]  # (4 - t_i) × 0.5 h
    assert set(st["method"]) == {"marops"}


def test_routes_hand_values(tables, plan):
    rt = tables[1].to_pydict()
    assert rt["drone"] == [0, 1]
    assert (rt["start_depot"], rt["end_depot"], rt["action"]) == ([0, 1], [0, 1], [0, 0])
    assert rt["n_parcels"] == [2, 0]
    assert rt["payload_kg"] == [2.5, 0.0]
    assert_allclose(rt["distance_m"], [3000.0, 0.0])
    e0 = plan.routes[0].energy_j
    assert_allclose(rt["energy_j"], [e0, 0.0])
    assert_allclose(rt["battery_frac"], [e0 / 225_000.0, 0.0])
    assert_allclose(e0, 64_033.0, rtol=1e-4)


def test_records_are_json_ready(tables):
    rows = table_records(tables[1])
    assert rows[0]["window_start"] == "2022-08-11T11:00:00+08:00"
    assert rows[0]["day"] == "2022-08-11"
    json.dumps(rows, allow_nan=False)


def test_write_route_files(tables, tmp_path: Path):
    stops, routes = tables
    meta = {"package": "marops", "method": "marops", "seed": 0}
    with output_set() as files:
        written = write_route_files(files, tmp_path / "pq", stops, routes, meta)
    assert written == [tmp_path / "pq" / "stops.parquet", tmp_path / "pq" / "routes.parquet"]
    assert sorted(p.name for p in (tmp_path / "pq").iterdir()) == [
        "routes.parquet",
        "stops.parquet",
    ]
    for path, table in zip(written, tables, strict=True):
        back = pq.read_table(path)
        assert json.loads(back.schema.metadata[b"marops"]) == meta
        assert back.drop_columns(["geometry"]).to_pydict() == table.to_pydict()

    with output_set() as files:
        paths = write_route_files(files, tmp_path / "js", stops, routes, meta, "json", True)
    assert [p.name for p in paths] == ["stops.json", "routes.json", "routes.geojson"]
    assert json.loads(paths[0].read_text()) == {"meta": meta, "stops": table_records(stops)}
    assert json.loads(paths[1].read_text()) == {"meta": meta, "routes": table_records(routes)}

    first = written[0].read_bytes()
    with output_set() as files:
        write_route_files(files, tmp_path / "pq", stops, routes, meta)
    assert written[0].read_bytes() == first  # same tables, same bytes


def test_route_parquet_files_are_geoparquet(tables, tmp_path: Path):
    """GeoParquet 1.1.0: a WKB ``geometry`` column (a stop's point, a route's line through
    its stops in visiting order) named by the ``geo`` metadata, CRS the default
    OGC:CRS84 (longitude, latitude), so geopandas reads the files as they are."""
    import shapely

    stops, routes = tables
    with output_set() as files:
        written = write_route_files(files, tmp_path, stops, routes, {"method": "marops"})
    for path, kind in zip(written, ("Point", "LineString"), strict=True):
        back = pq.read_table(path)
        geo = json.loads(back.schema.metadata[b"geo"])
        assert geo["version"] == "1.1.0" and geo["primary_column"] == "geometry"
        assert geo["columns"] == {"geometry": {"encoding": "WKB", "geometry_types": [kind]}}
        assert back.schema.field("geometry").type == "binary"
        assert back.schema.names[-1] == "geometry" and b"marops" in back.schema.metadata
    points = shapely.from_wkb(pq.read_table(written[0]).column("geometry").to_pylist())
    assert [(p.x, p.y) for p in points] == list(
        zip(stops.column("lng").to_pylist(), stops.column("lat").to_pylist(), strict=True)
    )
    lines = shapely.from_wkb(pq.read_table(written[1]).column("geometry").to_pylist())
    flown = [(p.x, p.y) for p in points[:4]]  # drone 0: depot 0, o40, o43, depot 0
    assert list(lines[0].coords) == flown and len(lines[1].coords) == 2

    gpd = pytest.importorskip("geopandas")
    frame = gpd.read_parquet(written[0])
    assert frame.crs is not None and frame.crs.equals("OGC:CRS84")
    assert frame.geometry.x.tolist() == stops.column("lng").to_pylist()
    assert gpd.read_parquet(written[1]).geometry.geom_type.tolist() == ["LineString"] * 2


def test_routes_geojson_by_hand(tables):
    """Drone 0 flies depot 0 -> o40 -> o43 -> depot 0: a closed LineString of 4 points
    whose length in metres (local frame) is the route's distance_m; drone 1 stays."""
    stops, routes = tables
    doc = routes_geojson(stops, routes, {"method": "marops"})
    assert doc["type"] == "FeatureCollection" and len(doc["features"]) == 2
    line = doc["features"][0]["geometry"]
    assert line["type"] == "LineString" and len(line["coordinates"]) == 4
    lng, lat = np.array(line["coordinates"]).T
    x, y = FRAME.to_xy(lng, lat)
    assert_allclose(np.hypot(np.diff(x), np.diff(y)).sum(), 3000.0, rtol=1e-9)
    props = doc["features"][0]["properties"]
    assert (props["drone"], props["n_parcels"], props["window"]) == (0, 2, T)
    assert props["energy_j"] == routes.column("energy_j")[0].as_py()
    json.dumps(doc, allow_nan=False)


def test_write_route_files_bad_format_leaves_nothing(tables, tmp_path: Path):
    with pytest.raises(ValueError, match="parquet or json"), output_set() as files:
        write_route_files(files, tmp_path, *tables, {}, "csv")
    assert list(tmp_path.iterdir()) == []


def test_an_error_midway_leaves_no_file(tables, tmp_path: Path):
    with pytest.raises(RuntimeError), output_set() as files:
        write_route_files(files, tmp_path, *tables, {})
        raise RuntimeError("disk full")
    assert list(tmp_path.iterdir()) == []


def test_outputs_get_umask_permissions_not_mkstemp_0600(tmp_path) -> None:
    import os

    from marops_cli.io import output_set

    old = os.umask(0o022)
    try:
        with output_set() as files:
            files.write_json(tmp_path / "m.json", {"a": 1})
    finally:
        os.umask(old)
    assert (tmp_path / "m.json").stat().st_mode & 0o777 == 0o644
    assert [p.name for p in tmp_path.iterdir()] == ["m.json"]
