"""The hubs on a map (docs/outputs.md, "Hubs file"): ``segment --hubs`` writes the hubs
GeoJSON beside the hubs file (each hub's square and its depots) and, with ``--plot``, a
PNG map of them."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import shapely
from shapely.geometry import shape
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.data.frame import Frame

runner = CliRunner()


def _segment(*args: object) -> str:
    res = runner.invoke(app, ["segment", *(str(a) for a in args)])
    assert res.exit_code == 0, res.output
    return res.output


@pytest.fixture(scope="module")
def hubs(example_csv: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``segment --hubs 3 --plot`` on one day of the example."""
    out = tmp_path_factory.mktemp("hubmap") / "hubs.json"
    _segment(example_csv, "--hubs", 3, "--dates", "0801", "--plot", "--out", out, "--quiet")
    return out


def test_the_hubs_geojson_holds_each_hubs_square_and_its_depots(hubs: Path) -> None:
    """Per hub of hubs.json a Polygon (its square, counter-clockwise, 10 km a side around
    its centre) with its id and orders, then its 16 depots ([segment] n_depots), each a
    Point inside its hub's square; the FeatureCollection's marops member is the hubs
    file's meta."""
    doc = json.loads(hubs.read_text())
    gj = json.loads(hubs.with_suffix(".geojson").read_text())
    assert gj["type"] == "FeatureCollection" and gj["marops"] == doc["meta"]
    squares = [f for f in gj["features"] if f["properties"]["kind"] == "hub"]
    assert [f["properties"]["hub"] for f in squares] == [h["id"] for h in doc["hubs"]]
    for h, f in zip(doc["hubs"], squares, strict=True):
        assert f["properties"]["orders"] == h["orders"]
        assert f["geometry"]["type"] == "Polygon"
        ring = shape(f["geometry"]).exterior
        assert ring.is_ccw
        frame = Frame(h["center_lng"], h["center_lat"], h["size_km"])
        x, y = frame.to_xy(*np.asarray(ring.coords).T)
        np.testing.assert_allclose(np.abs(x), 5000.0, atol=0.1)
        np.testing.assert_allclose(np.abs(y), 5000.0, atol=0.1)
        depots = [
            g for g in gj["features"]
            if g["properties"]["kind"] == "depot" and g["properties"]["hub"] == h["id"]
        ]  # fmt: skip
        assert [d["properties"]["depot"] for d in depots] == list(range(16))
        assert f["properties"]["depots"] == 16
        points = shapely.points([d["geometry"]["coordinates"] for d in depots])
        assert frame.contains(*frame.to_xy(*shapely.get_coordinates(points).T)).all()


def test_plot_draws_the_hubs_map_beside_the_hubs_file(hubs: Path) -> None:
    png = hubs.with_suffix(".png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_hub_too_sparse_for_its_depots_is_drawn_without_them(
    example_csv: Path, tmp_path: Path
) -> None:
    """More depots asked for than a hub's square holds orders: a warning naming the hub;
    its square is in the GeoJSON with no depot, the others' depots are."""
    cfg = tmp_path / "many.toml"
    cfg.write_text("[segment]\nn_depots = 60\n")
    out = tmp_path / "hubs.json"
    text = _segment(example_csv, "--hubs", "auto", "--dates", "0801", "--config", cfg, "--out", out)
    warned = [line for line in text.splitlines() if "no depots drawn" in line]
    assert warned and all(w.startswith("warning: hub ") for w in warned), text
    sparse = {int(w.split()[2].rstrip(":")) for w in warned}
    gj = json.loads(out.with_suffix(".geojson").read_text())
    props = [f["properties"] for f in gj["features"]]
    for p in props:
        if p["kind"] == "hub":
            assert p["depots"] == (0 if p["hub"] in sparse else 60)
    assert not [p for p in props if p["kind"] == "depot" and p["hub"] in sparse]
    assert {p["hub"] for p in props if p["kind"] == "depot"} == {
        p["hub"] for p in props if p["kind"] == "hub"
    } - sparse


def test_the_api_writes_the_same_files(example_csv: Path, hubs: Path, tmp_path: Path) -> None:
    """``segment(hubs=..., plot=True)`` writes what the command writes, the same bytes."""
    from marops_cli import api

    out = tmp_path / "hubs.json"
    api.segment(example_csv, hubs=3, dates="0801", out=out, plot=True)
    for suffix in (".json", ".geojson"):
        assert out.with_suffix(suffix).read_bytes() == hubs.with_suffix(suffix).read_bytes()
    assert out.with_suffix(".png").is_file()
