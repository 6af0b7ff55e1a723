"""The files marops writes, read as an analyst's tools read them: the stops and routes
columns against docs/outputs.md's tables (name, order, type, which hold nulls), the JSON
route files and GeoJSON against the same columns, and every GeoJSON document valid RFC
7946 (positions lng, lat in range; rings closed and counter-clockwise; no leg jumping
round the globe at the antimeridian; no NaN); the files' metadata, a day's metrics.json
and synth's columns as documented."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.segment import line_geometry

DOCS = Path(__file__).resolve().parents[2] / "docs" / "outputs.md"
runner = CliRunner()
STOPS, ROUTES = "Stops: one row per visited node", "Routes: one row per drone and window"

# docs/outputs.md's words for a column's type, as Parquet stores it.
DOC_TYPES = {
    "int32": pa.int32(),
    "int64": pa.int64(),
    "float64": pa.float64(),
    "string": pa.string(),
    "date": pa.date32(),
    "timestamp with zone": pa.timestamp("ms", tz="Asia/Shanghai"),
    "binary": pa.binary(),
}


def doc_table(heading: str) -> list[tuple[str, pa.DataType, bool]]:
    """``(column, type, may hold nulls)`` in the order of the table under ``heading``;
    a row naming several columns gives each; ``as in stops`` takes the stops' type."""
    text = DOCS.read_text(encoding="utf-8")
    section = text.split(f"\n## {heading}")[1].split("\n## ")[0]
    stops = {} if heading.startswith("Stops") else {n: (t, z) for n, t, z in doc_table(STOPS)}
    out: list[tuple[str, pa.DataType, bool]] = []
    for cells in re.findall(r"^\| (`[^|]+?) \| ([^|]*?) \|", section, flags=re.M):
        kind = cells[1].strip()
        for name in re.findall(r"`(\w+)`", cells[0]):
            if kind.startswith("as in stops"):
                out.append((name, *stops[name]))
                continue
            base, _, rest = kind.partition(",")
            assert base in DOC_TYPES, (heading, name, kind)
            out.append((name, DOC_TYPES[base], "null for" in rest))
    assert out, heading
    return out


@pytest.fixture(scope="module")
def window(example_csv: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A window planned on the example: Parquet route files and routes.geojson."""
    out = tmp_path_factory.mktemp("window")
    args = ["segment", str(example_csv), "--dates", "0801..0810", "--out"]
    res = runner.invoke(app, [*args, str(out / "depots.json"), "--geojson"])
    assert res.exit_code == 0, res.output
    args = ["plan-window", str(example_csv), "--depots", str(out / "depots.json")]
    args += ["--date", "0811", "--window", "5", "--geojson"]
    for fmt in ("parquet", "json"):
        res = runner.invoke(app, [*args, "--format", fmt, "--out", str(out / fmt)])
        assert res.exit_code == 0, res.output
    return out


@pytest.mark.parametrize(
    ("heading", "name"),
    [(STOPS, "stops"), (ROUTES, "routes")],
)
def test_route_files_are_as_documented(window: Path, heading: str, name: str) -> None:
    """Every documented column, in the documented order and type, and no other; only
    the columns documented as null somewhere hold a null."""
    documented = doc_table(heading)
    table = pq.read_table(window / "parquet" / f"{name}.parquet")
    assert [(f.name, f.type) for f in table.schema] == [(n, t) for n, t, _ in documented]
    for column, _, nullable in documented:
        assert (table.column(column).null_count > 0) == nullable, column
    # The JSON route files hold the same columns but the Parquet files' GeoParquet
    # geometry, in the same order, and the same rows.
    columns = [c for c in table.column_names if c != "geometry"]
    assert table.column_names == [*columns, "geometry"]
    doc = json.loads((window / "json" / f"{name}.json").read_text())
    assert list(doc) == ["meta", name]
    assert [list(r) for r in doc[name]] == [columns] * table.num_rows
    # Every route's properties in routes.geojson are its columns.
    if name == "routes":
        gj = json.loads((window / "parquet" / "routes.geojson").read_text())
        assert [list(f["properties"]) for f in gj["features"]] == [columns] * len(gj["features"])


def _strict(path: Path) -> Any:
    """A JSON document that holds no NaN or infinity (which are no JSON)."""

    def refuse(word: str) -> None:
        raise AssertionError(f"{path}: {word}")

    return json.loads(path.read_text(encoding="utf-8"), parse_constant=refuse)


def _ccw(ring: list[list[float]]) -> bool:
    return sum((b[0] - a[0]) * (b[1] + a[1]) for a, b in zip(ring[:-1], ring[1:], strict=True)) < 0


def check_rfc7946(path: Path) -> dict[str, int]:
    """Assert that ``path`` is a FeatureCollection RFC 7946 accepts; the count of each
    geometry type."""
    doc = _strict(path)
    assert doc["type"] == "FeatureCollection"
    kinds: dict[str, int] = {}

    def position(p: list[float]) -> None:
        assert len(p) == 2 and -180 <= p[0] <= 180 and -90 <= p[1] <= 90, p

    def line(coords: list[list[float]]) -> None:
        assert len(coords) >= 2
        for p in coords:
            position(p)
        for a, b in zip(coords[:-1], coords[1:], strict=True):
            assert abs(b[0] - a[0]) < 180, (a, b)  # no leg round the globe

    for f in doc["features"]:
        assert f["type"] == "Feature" and isinstance(f["properties"], dict)
        json.dumps(f["properties"], allow_nan=False)
        g = f["geometry"]
        kinds[g["type"]] = kinds.get(g["type"], 0) + 1
        if g["type"] == "Point":
            position(g["coordinates"])
        elif g["type"] in ("LineString", "MultiLineString"):
            for part in [g["coordinates"]] if g["type"] == "LineString" else g["coordinates"]:
                line(part)
        else:
            assert g["type"] in ("Polygon", "MultiPolygon"), g["type"]
            for poly in [g["coordinates"]] if g["type"] == "Polygon" else g["coordinates"]:
                for k, ring in enumerate(poly):
                    line(ring)
                    assert len(ring) >= 4 and ring[0] == ring[-1]  # closed
                    assert _ccw(ring) == (k == 0)  # outer ring counter-clockwise
    return kinds


def test_geojson_files_are_rfc7946(window: Path) -> None:
    assert check_rfc7946(window / "depots.geojson") == {"Polygon": 16, "Point": 16}
    assert set(check_rfc7946(window / "parquet" / "routes.geojson")) == {"LineString"}


def test_a_path_across_the_antimeridian_is_cut_there() -> None:
    """Cut at 180° where each crossing leg meets it, the parts in the path's order; a
    path that stays on one side keeps its positions to the bit."""
    geom = line_geometry([179.999, -179.999, 179.998], [31.0, 31.0, 31.1])
    assert geom["type"] == "MultiLineString"
    a, b, c = geom["coordinates"]
    assert a == [[179.999, 31.0], [180.0, 31.0]]
    assert b[0] == [-180.0, 31.0] and b[1] == [-179.999, 31.0] and b[2][0] == -180.0
    assert c[0][0] == 180.0 and c[1] == [179.998, 31.1]
    # the leg back west meets 180° a third of its way (0.001° of its 0.003°)
    assert b[2][1] == c[0][1] == pytest.approx(31.0 + 0.1 / 3, abs=1e-9)
    lng, lat = [121.47, 121.4812345678901, 121.47], [31.23, 31.24, 31.23]
    assert line_geometry(lng, lat) == {
        "type": "LineString",
        "coordinates": [list(p) for p in zip(lng, lat, strict=True)],
    }
    assert line_geometry([-179.99, -179.98], [0.0, 0.0])["type"] == "LineString"


def test_routes_across_the_antimeridian_are_multilinestrings(
    example_csv: Path, tmp_path: Path
) -> None:
    """The example moved to a city across 180°: routes.geojson cuts the routes that cross
    it (RFC 7946 §3.1.9), as depots.geojson cuts the service areas, and each route's
    positions, cut points aside, are its stops' in visiting order."""
    lines = example_csv.read_text().splitlines()
    i_lng = lines[0].split(",").index("lng")
    shift = 179.995 - 121.4468  # the example's study square centred just west of 180°
    rows = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        if cells[i_lng]:
            cells[i_lng] = f"{(float(cells[i_lng]) + shift + 180.0) % 360.0 - 180.0:.6f}"
        rows.append(",".join(cells))
    data = tmp_path / "across.csv"
    data.write_text("\n".join(rows) + "\n")
    depots, out = tmp_path / "depots.json", tmp_path / "w"
    args = ["segment", str(data), "--dates", "0801..0810", "--out", str(depots), "--geojson"]
    assert runner.invoke(app, args).exit_code == 0
    args = ["plan-window", str(data), "--depots", str(depots), "--date", "0811"]
    res = runner.invoke(app, [*args, "--window", "5", "--out", str(out), "--geojson"])
    assert res.exit_code == 0, res.output

    assert check_rfc7946(tmp_path / "depots.geojson").get("MultiPolygon", 0) > 0
    kinds = check_rfc7946(out / "routes.geojson")
    assert kinds.get("MultiLineString", 0) > 0
    stops = pq.read_table(out / "stops.parquet").to_pylist()
    for f in json.loads((out / "routes.geojson").read_text())["features"]:
        g, drone = f["geometry"], f["properties"]["drone"]
        parts = [g["coordinates"]] if g["type"] == "LineString" else g["coordinates"]
        if g["type"] == "MultiLineString":
            # each cut: the same point on both sides
            for a, b in zip(parts[:-1], parts[1:], strict=True):
                assert abs(a[-1][0]) == abs(b[0][0]) == 180.0 and a[-1][1] == b[0][1]
        kept = [p for part in parts for p in part if abs(p[0]) != 180.0]
        own = sorted((s["seq"], [s["lng"], s["lat"]]) for s in stops if s["drone"] == drone)
        assert kept == [p for _, p in own]
    lng = np.array([s["lng"] for s in stops])
    assert lng.min() < -179.9 and lng.max() > 179.9  # both sides of the line


# docs/outputs.md, the files' metadata: what every output records, and what each adds.
PROVENANCE = ["package", "version", "command", "config", "input", "policy", "method", "seed"]
PLAN_WINDOW = ["day", "window", "solver", "objective", "frame", "depots_file", "fleet"]


def test_provenance_is_as_documented(window: Path) -> None:
    text = DOCS.read_text(encoding="utf-8")
    for key in PROVENANCE + PLAN_WINDOW:
        assert f"`{key}`" in text, key
    for name in ("stops", "routes"):
        schema = pq.read_schema(window / "parquet" / f"{name}.parquet")
        meta = json.loads(schema.metadata[b"marops"])
        assert list(meta) == PROVENANCE + PLAN_WINDOW
        assert list(meta["input"]) == ["name", "size", "sha256"]
        assert list(meta["objective"])[:2] == ["J", "G"]
        assert json.loads((window / "json" / f"{name}.json").read_text())["meta"] == meta
    assert json.loads((window / "parquet" / "routes.geojson").read_text())["marops"] == meta
    depots = json.loads((window / "depots.json").read_text())["meta"]
    assert list(depots) == [k for k in PROVENANCE if k != "policy"] + ["days", "n_history", "rows"]
    assert json.loads((window / "depots.geojson").read_text())["marops"] == depots


def test_synth_writes_the_documented_columns(tmp_path: Path) -> None:
    """synth's Parquet: docs/outputs.md's 17 columns in order, times as text, no metadata."""
    row = next(r for r in DOCS.read_text("utf-8").splitlines() if r.startswith("| `synth"))
    names = re.findall(r"`(\w+)`", row.split("in its order (")[1].split(")")[0])
    out = tmp_path / "lade.parquet"
    args = ["synth", "--days", "1", "--orders-per-day", "60", "--out", str(out)]
    assert runner.invoke(app, args).exit_code == 0
    schema = pq.read_schema(out)
    assert schema.names == names and len(names) == 17
    assert {str(f.type) for f in schema} <= {"int64", "double", "string"}
    assert schema.field("accept_time").type == pa.string() and schema.metadata is None


def test_geojson_help_names_the_cut_lines() -> None:
    for command in ("replay-day", "plan-window"):
        res = runner.invoke(app, [command, "--help"], env={"COLUMNS": "200"})
        assert "MultiLineString cut at 180°" in " ".join(res.output.split()), command


def test_a_days_metrics_are_as_documented(example_csv: Path, window: Path, tmp_path: Path) -> None:
    """metrics.json of a replayed day: every key of docs/outputs.md's "Day metrics" table
    (but the two of `[plan] bound`) and no other; its meta the route files' keys with
    `created` and `settings`."""
    text = DOCS.read_text(encoding="utf-8")
    section = text.split("\n## Day metrics")[1].split("\n## ")[0]
    documented = {
        name
        for cells in re.findall(r"^\| (`[^|]+?) \|", section, flags=re.M)
        for name in re.findall(r"`(\w+)`", cells)
    }
    args = ["replay-day", str(example_csv), "--depots", str(window / "depots.json")]
    res = runner.invoke(app, [*args, "--date", "0811", "--method", "stay", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    doc = _strict(tmp_path / "metrics.json")
    (day,) = doc["days"]
    assert set(day) == documented - {"objective_bound_mj", "gap_median"}
    meta = json.loads(pq.read_schema(tmp_path / "routes.parquet").metadata[b"marops"])
    assert set(meta) == {*PROVENANCE, "frame", "depots_file", "fleet", "day"}
    assert set(doc["meta"]) == set(meta) | {"created", "settings"}
