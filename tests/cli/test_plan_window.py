"""``marops plan-window`` on the bundled example: files, types, metadata, options, and
the same result as the library call."""

from __future__ import annotations

import datetime as dt
import hashlib
import json
from pathlib import Path
from typing import Any
from zoneinfo import ZoneInfo

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from marops_cli import __version__
from marops_cli.cli.app import app
from marops_cli.config import PlannerConfig
from marops_cli.energy import EnergyModel
from marops_cli.io.tables import build_tables
from marops_cli.sim.scenario import load_fleet, load_scenario, method_policy, plan_one_window

runner = CliRunner()
DAY = dt.date(2022, 8, 11)
WINDOW = 5

# docs/outputs.md, column by column. Parquet has no second-resolution timestamp (only milli-,
# micro- and nanoseconds), so a timestamp[s] column is stored and read back as
# timestamp[ms]; the values stay whole seconds, local times of the data's zone.
TS = pa.timestamp("ms", tz="Asia/Shanghai")
SHANGHAI = ZoneInfo("Asia/Shanghai")
STOPS_COLUMNS = [
    ("hub", pa.int32()),
    ("day", pa.date32()),
    ("window", pa.int32()),
    ("window_start", TS),
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
    ("arrive_time", TS),
    ("leg_m", pa.float64()),
    ("leg_j", pa.float64()),
    ("payload_kg", pa.float64()),
    ("weight_kg", pa.float64()),
    ("due_window", pa.int32()),
    ("delay_h", pa.float64()),
    ("method", pa.string()),
    ("geometry", pa.binary()),  # GeoParquet: WKB, Parquet files only
]
ROUTES_COLUMNS = [
    ("hub", pa.int32()),
    ("day", pa.date32()),
    ("window", pa.int32()),
    ("window_start", TS),
    ("drone", pa.int32()),
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
    ("geometry", pa.binary()),
]


@pytest.fixture(scope="module")
def depots_file(example_csv: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("seg") / "depots.json"
    res = runner.invoke(
        app, ["segment", str(example_csv), "--dates", "0801..0810", "--out", str(out)]
    )
    assert res.exit_code == 0, res.output
    return out


def plan(example_csv: Path, depots_file: Path, out: Path, *extra: str) -> Path:
    args = ["plan-window", str(example_csv), "--depots", str(depots_file), "--method", "greedy"]
    args += ["--date", "0811", "--window", str(WINDOW), "--out", str(out), *extra]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    return out


def routes_path(out: Path) -> Path:
    return out / "routes.parquet"


def stops_path(out: Path) -> Path:
    return out / "stops.parquet"


def records(table: pa.Table) -> list[dict[str, Any]]:
    """Rows as the JSON output writes them (times as ISO text in the data's zone; no
    GeoParquet geometry, which only the Parquet files hold)."""
    if "geometry" in table.column_names:
        table = table.drop_columns(["geometry"])
    rows = table.to_pylist()
    for row in rows:
        for k, v in row.items():
            if isinstance(v, dt.datetime):
                row[k] = v.astimezone(SHANGHAI).isoformat()
            elif isinstance(v, dt.date):
                row[k] = v.isoformat()
    return rows


def meta_of(path: Path) -> dict[str, Any]:
    raw = pq.read_schema(path).metadata
    assert raw is not None and b"marops" in raw
    return json.loads(raw[b"marops"])


@pytest.fixture(scope="module")
def parquet_out(example_csv, depots_file, tmp_path_factory) -> Path:
    return plan(example_csv, depots_file, tmp_path_factory.mktemp("pq") / "w5")


def test_a_window_planned_again_leaves_none_of_the_earlier_runs_other_files(
    example_csv: Path, depots_file: Path, tmp_path: Path
) -> None:
    """Planned again into its folder with other options, a window's folder holds only
    this run's files: the JSON route files and the map of a run with --format json
    --geojson go, where they stayed beside the new Parquet files, planned for another
    fleet; a file marops did not write stays."""
    out = plan(example_csv, depots_file, tmp_path / "w", "--format", "json", "--geojson")
    (out / "report.html").write_text("a user's own page")
    plan(example_csv, depots_file, out, "--drones", "2")
    names = sorted(p.name for p in out.iterdir() if not p.name.startswith("."))
    assert names == ["report.html", "routes.parquet", "stops.parquet"]
    assert (out / "report.html").read_text() == "a user's own page"
    # An earlier window's stops file read with --delivered is an input: it stays.
    plan(
        example_csv, depots_file, out, "--format", "json", "--delivered", str(out / "stops.parquet")
    )
    assert (out / "stops.parquet").is_file() and not (out / "routes.parquet").exists()


def test_parquet_writes_stops_and_routes_with_the_documented_columns(parquet_out):
    stops = pq.read_table(stops_path(parquet_out))
    routes = pq.read_table(routes_path(parquet_out))
    assert [(f.name, f.type) for f in stops.schema] == STOPS_COLUMNS
    assert [(f.name, f.type) for f in routes.schema] == ROUTES_COLUMNS
    assert sorted(p.name for p in parquet_out.iterdir()) == [
        "routes.parquet",
        "stops.parquet",
    ], "no temporaries left behind"

    st, rt = stops.to_pydict(), routes.to_pydict()
    assert rt["drone"] == list(range(8))  # one row per drone (default fleet: 8)
    assert set(rt["window"]) == {WINDOW} and set(st["window"]) == {WINDOW}
    assert set(st["day"]) == {DAY} and set(rt["method"]) == {"greedy"}
    ws = dt.datetime(2022, 8, 11, 11, 30, tzinfo=SHANGHAI)  # 09:00 + 5 × 30 min, local
    assert set(rt["window_start"]) == {ws}
    for a_s, a_t in zip(st["arrive_s"], st["arrive_time"], strict=True):
        assert a_t == ws + dt.timedelta(seconds=int(a_s))
    assert sum(rt["n_parcels"]) > 0
    # nulls where docs/outputs.md says so
    for i, kind in enumerate(st["kind"]):
        depot_row = kind in ("start", "end")
        assert (st["depot"][i] is None) == (not depot_row)
        for name in ("order_id", "weight_kg", "due_window", "delay_h"):
            assert (st[name][i] is None) == depot_row, (name, i)
    # the stops add up to their route
    for u in rt["drone"]:
        rows = [i for i, d in enumerate(st["drone"]) if d == u]
        assert [st["seq"][i] for i in rows] == list(range(len(rows)))
        assert len(rows) == rt["n_parcels"][u] + 2
        assert st["depot"][rows[0]] == rt["start_depot"][u]
        assert st["depot"][rows[-1]] == rt["end_depot"][u]
        assert_allclose(sum(st["leg_j"][i] for i in rows), rt["energy_j"][u], rtol=1e-12)
        assert_allclose(sum(st["leg_m"][i] for i in rows), rt["distance_m"][u], rtol=1e-12)
        assert st["payload_kg"][rows[0]] == pytest.approx(rt["payload_kg"][u])
        assert rt["battery_frac"][u] == pytest.approx(rt["energy_j"][u] / 225_000.0)


def test_parquet_metadata(parquet_out, example_csv: Path):
    meta = meta_of(stops_path(parquet_out))
    assert meta_of(routes_path(parquet_out)) == meta
    assert meta["version"] == __version__
    assert meta["config"] == PlannerConfig().model_dump(mode="json")
    data = example_csv.read_bytes()
    assert meta["input"] == {
        "name": "shanghai_synth.csv",
        "size": len(data),
        "sha256": hashlib.sha256(data).hexdigest(),
    }
    assert meta["method"] == "greedy"
    assert meta["seed"] == 0
    assert meta["policy"] == {"name": "greedy"}
    assert (meta["day"], meta["window"]) == ("2022-08-11", WINDOW)
    assert meta["solver"]["status"] == "optimal" and meta["solver"]["fallback"] is False
    assert "created" not in meta  # run times stay out of route files (byte-identical reruns)


def test_json_holds_meta_stops_routes_equal_to_the_parquet(
    example_csv, depots_file, parquet_out, tmp_path
):
    out = plan(example_csv, depots_file, tmp_path / "w5", "--format", "json", "--geojson")
    assert sorted(p.name for p in out.iterdir()) == ["routes.geojson", "routes.json", "stops.json"]
    stops = json.loads((out / "stops.json").read_text(encoding="utf-8"))
    routes = json.loads((out / "routes.json").read_text(encoding="utf-8"))
    assert list(stops) == ["meta", "stops"] and list(routes) == ["meta", "routes"]
    assert stops["meta"] == routes["meta"] == meta_of(stops_path(parquet_out))
    assert stops["stops"] == records(pq.read_table(stops_path(parquet_out)))
    assert routes["routes"] == records(pq.read_table(routes_path(parquet_out)))
    assert routes["routes"][0]["window_start"] == "2022-08-11T11:30:00+08:00"
    # routes.geojson: one LineString per route in lng/lat, its length the route's distance
    from marops_cli.data.frame import Frame

    gj = json.loads((out / "routes.geojson").read_text(encoding="utf-8"))
    frame = Frame(**stops["meta"]["frame"])
    assert len(gj["features"]) == len(routes["routes"])
    for feat, row in zip(gj["features"], routes["routes"], strict=True):
        assert feat["geometry"]["type"] == "LineString"
        lng, lat = np.array(feat["geometry"]["coordinates"]).T
        assert len(lng) == row["n_parcels"] + 2
        x, y = frame.to_xy(lng, lat)
        length = float(np.hypot(np.diff(x), np.diff(y)).sum())
        assert length == pytest.approx(row["distance_m"], rel=0.01, abs=1e-6)
        assert feat["properties"]["energy_j"] == row["energy_j"]


def test_quiet_prints_neither_the_routes_nor_the_objective(example_csv, depots_file, tmp_path):
    """--quiet keeps warnings and errors only: no routes table, no objective line."""
    args = ["plan-window", str(example_csv), "--depots", str(depots_file), "--method", "stay"]
    args += ["--date", "0811", "--window", "0", "--drones", "2", "--out", str(tmp_path), "-q"]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert res.stdout == "" and (tmp_path / "routes.parquet").is_file()


def test_same_call_same_bytes(example_csv, depots_file, parquet_out, tmp_path):
    again = plan(example_csv, depots_file, tmp_path / "w5")
    assert stops_path(again).read_bytes() == stops_path(parquet_out).read_bytes()
    assert routes_path(again).read_bytes() == routes_path(parquet_out).read_bytes()
    a = plan(example_csv, depots_file, tmp_path / "a", "--format", "json")
    b = plan(example_csv, depots_file, tmp_path / "b", "--format", "json")
    assert (a / "stops.json").read_bytes() == (b / "stops.json").read_bytes()


@pytest.mark.parametrize(
    "doc",
    [[3, 3, 12], {"drones": [{"depot": 3}, {"depot": 3}, {"depot": 12}]}],
    ids=["list", "dict"],
)
def test_fleet_file_puts_drones_where_asked(example_csv, depots_file, tmp_path, doc):
    fleet = tmp_path / "fleet.json"
    fleet.write_text(json.dumps(doc))
    out = plan(example_csv, depots_file, tmp_path / "f", "--fleet", str(fleet))
    rt = pq.read_table(routes_path(out)).to_pydict()
    assert rt["drone"] == [0, 1, 2]
    assert rt["start_depot"] == [3, 3, 12]
    st = pq.read_table(stops_path(out)).to_pydict()
    starts = [
        (d, dep)
        for d, k, dep in zip(st["drone"], st["kind"], st["depot"], strict=True)
        if k == "start"
    ]
    assert starts == [(0, 3), (1, 3), (2, 12)]


def test_delivered_orders_are_not_planned_again(example_csv, depots_file, parquet_out, tmp_path):
    def customers(path: Path) -> list[str]:
        st = pq.read_table(path, columns=["kind", "order_id"]).to_pydict()
        return [o for k, o in zip(st["kind"], st["order_id"], strict=True) if k == "customer"]

    first = customers(stops_path(parquet_out))
    assert first
    out = plan(example_csv, depots_file, tmp_path / "w5b", "--delivered", str(parquet_out))
    second = customers(stops_path(out))
    assert second, "other pending orders are planned instead"
    assert not set(first) & set(second)


@pytest.mark.parametrize("force", [[], ["--force"]], ids=["plain", "force"])
def test_delivered_folder_is_never_the_output(example_csv, depots_file, tmp_path, force):
    # --delivered DIR reads DIR/stops.parquet: writing the plan to the same DIR would
    # replace the input it reads, so it is refused like --delivered DIR/stops.parquet.
    out = plan(example_csv, depots_file, tmp_path / "w")
    before = stops_path(out).read_bytes()
    args = ["plan-window", str(example_csv), "--depots", str(depots_file), "--method", "greedy"]
    args += ["--date", "0811", "--window", str(WINDOW + 1), "--out", str(out)]
    res = runner.invoke(app, [*args, "--delivered", str(out), *force])
    assert res.exit_code == 2
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and "is an input of this run" in lines[0], res.output
    assert stops_path(out).read_bytes() == before


def test_cli_equals_library_call(example_csv, depots_file, parquet_out):
    cfg = PlannerConfig()
    scn = load_scenario(example_csv, cfg, depots_path=depots_file, replay_days=[DAY])
    fleet = load_fleet(None, scn.depots, cfg.sim.drones, cfg)
    plan_, reqs = plan_one_window(scn, DAY, WINDOW, fleet, method_policy("greedy", None, 0))

    rt = pq.read_table(routes_path(parquet_out)).to_pydict()
    st = pq.read_table(stops_path(parquet_out)).to_pydict()
    assert [r.start for r in plan_.routes] == rt["start_depot"]
    assert [r.end for r in plan_.routes] == rt["end_depot"]
    assert [r.action for r in plan_.routes] == rt["action"]
    assert [len(r.stops) for r in plan_.routes] == rt["n_parcels"]
    assert_allclose([r.energy_j for r in plan_.routes], rt["energy_j"], rtol=1e-12)
    assert_allclose([r.payload_kg for r in plan_.routes], rt["payload_kg"], rtol=1e-12)
    for r in plan_.routes:
        ids = [
            o
            for d, k, o in zip(st["drone"], st["kind"], st["order_id"], strict=True)
            if d == r.drone and k == "customer"
        ]
        assert ids == [str(reqs.order_id[i]) for i in r.stops]  # same orders, same visiting order
    # and the whole tables, value for value
    stops, routes = build_tables(reqs, scn.depots, [plan_], EnergyModel(cfg.energy), "greedy")
    assert records(stops) == records(pq.read_table(stops_path(parquet_out)))
    assert records(routes) == records(pq.read_table(routes_path(parquet_out)))
    assert np.array_equal(fleet.depot, rt["start_depot"])


def test_json_counts_the_rows_dropped_and_the_orders_left_out(
    example_csv, depots_file, tmp_path
) -> None:
    """``--json`` says what the data dropped and what the day left out, as the status
    lines do (the example drops 214 rows; most of its orders lie outside the square)."""
    args = ["plan-window", str(example_csv), "--depots", str(depots_file), "--method", "greedy"]
    args += ["--date", "0811", "--window", str(WINDOW), "--out", str(tmp_path / "w"), "--json"]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    rows, orders = doc["rows"], doc["orders"]
    assert rows["total"] == rows["kept"] + sum(rows["dropped"].values())
    assert rows["dropped"]["duplicate"] > 0 and rows["kept"] > 0
    assert orders["due"] == orders["planned"] + orders["outside_area"] + orders["outside_hours"]
    assert orders["outside_area"] > 0 and orders["planned"] > 0


def test_requests_no_drone_can_lift_are_said_as_replay_day_says_them(
    example_csv, depots_file, tmp_path
) -> None:
    """With a 0.5 kg payload the day's heavier parcels can never fly: plan-window warns
    with the count replay-day gives for the same day."""
    light = tmp_path / "light.toml"
    light.write_text("[energy]\nmax_payload_kg = 0.5\n")
    common = [str(example_csv), "--depots", str(depots_file), "--method", "greedy"]
    common += ["--date", "0811", "--config", str(light)]
    res = runner.invoke(
        app, ["plan-window", *common, "--window", str(WINDOW), "--out", str(tmp_path / "w")]
    )
    assert res.exit_code == 0, res.output
    said = [x for x in res.stderr.splitlines() if "heavier than the payload limit" in x]
    day = runner.invoke(app, ["replay-day", *common, "--out", str(tmp_path / "d")])
    assert day.exit_code == 0, day.output
    metrics = json.loads((tmp_path / "d" / "metrics.json").read_text())
    heavy = metrics["days"][0]["unservable_heavy"]
    assert heavy > 0
    assert said == [
        f"warning: 2022-08-11: {heavy:,} parcels heavier than the payload limit and 0 "
        "requests beyond any drone's reach from the nearest depot cannot be served"
    ]


def test_a_folder_whose_name_is_not_utf8_takes_the_outputs(
    example_csv: Path, depots_file: Path, parquet_out: Path, tmp_path: Path
) -> None:
    """pyarrow opened paths as UTF-8: an output folder named in another encoding gave a
    UnicodeEncodeError traceback, and a second run took its own files for foreign ones.
    Now the same bytes are written, the run repeats, and --delivered reads them."""
    import os

    out = tmp_path / os.fsdecode(b"\xc9\xcf\xba\xa3") / "w5"
    plan(example_csv, depots_file, out)
    plan(example_csv, depots_file, out)  # its own files: replaced, not refused
    for name in ("stops.parquet", "routes.parquet"):
        assert (out / name).read_bytes() == (parquet_out / name).read_bytes()
    plan(example_csv, depots_file, out.parent / "w6", "--delivered", str(out))


def test_delivered_leaves_out_only_the_requests_of_a_shared_id_it_delivered(tmp_path):
    """Rows that share an order id but not times or places are separate requests
    (docs/decisions.md, "Reading LaDe"): a stops file marks delivered only the one its
    stop reached (its id and place); a file without places, every request of the id."""
    from marops_cli.errors import InputError
    from marops_cli.sim.scenario import delivered_mask, delivered_orders

    class Reqs:  # the fields delivered_mask reads of a day's requests
        order_id = np.array(["7", "7", "8", "9"], dtype=object)
        lng = np.array([121.40, 121.50, 121.45, 121.46])
        lat = np.array([31.20, 31.25, 31.22, 31.23])

    placed = tmp_path / "stops.parquet"
    table = {
        "kind": ["start", "customer", "customer", "end"],
        "order_id": [None, "7", "8", None],
        "lng": [121.0, 121.50, 121.45, 121.0],
        "lat": [31.0, 31.25, 31.22, 31.0],
    }
    pq.write_table(pa.table(table), placed)
    assert delivered_mask(Reqs, delivered_orders(placed)).tolist() == [False, True, True, False]
    by_id = tmp_path / "by_id.parquet"
    pq.write_table(pa.table({k: table[k] for k in ("kind", "order_id")}), by_id)
    assert delivered_mask(Reqs, delivered_orders(by_id)).tolist() == [True, True, True, False]
    assert delivered_mask(Reqs, {"9"}).tolist() == [False, False, False, True]
    pq.write_table(pa.table({**table, "lng": ["x"] * 4}), placed)
    with pytest.raises(InputError, match="column of numbers"):
        delivered_orders(placed)
    # A stop of no place (written by hand) stands for every request of its id.
    pq.write_table(pa.table({**table, "lng": [121.0, None, 121.45, 121.0]}), placed)
    assert delivered_mask(Reqs, delivered_orders(placed)).tolist() == [True, True, True, False]
