"""Mixed fleets: fleet files, drone types, and a day replayed with them (docs/method.md §5.1)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.config import EnergyConfig
from marops_cli.data.frame import Frame
from marops_cli.energy import EnergyModel
from marops_cli.errors import InputError
from marops_cli.segment.depots import Depots, nearest_candidates
from marops_cli.sim.fleet import DEFAULT_TYPE, Fleet, default_fleet, load_fleet

ROOT = Path(__file__).resolve().parents[2]
runner = CliRunner()
BASE = EnergyConfig()


@pytest.fixture(scope="module")
def depots() -> Depots:
    xy = np.array([[0.0, 0.0], [1000.0, 0.0], [0.0, 1000.0]])
    return Depots(
        "kmeans", Frame(121.47, 31.23, 10.0), xy, np.array([5, 9, 7]), nearest_candidates(xy, 2)
    )


def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_no_file_is_the_default_type_over_the_busiest_depots(depots):
    fleet = load_fleet(None, depots, 4, BASE)
    assert fleet.depot.tolist() == [1, 2, 0, 1]  # 9, 7, 5 requests: busiest first, wrapping
    assert fleet.type_names() == [DEFAULT_TYPE] * 4
    assert fleet.types[0].energy == BASE and not fleet.mixed


def test_counts_types_and_models_built_once(tmp_path, depots):
    """Counts place drones as the default fleet does, types in file order; a type's
    parameters override [energy]; one energy model per type, shared by its drones."""
    path = _write(
        tmp_path,
        "f.toml",
        "[types.light]\nmax_payload_kg = 1.0\nspeed_ms = 14.0\n"
        "[types.heavy]\nmax_payload_kg = 4.0\nbattery_j = 400000.0\n"
        "[counts]\nlight = 2\nheavy = 3\n",
    )
    fleet = load_fleet(path, depots, 99, BASE)
    assert fleet.depot.tolist() == default_fleet(depots, 5).tolist()
    assert fleet.type_names() == ["light", "light", "heavy", "heavy", "heavy"]
    assert fleet.counts() == {"light": 2, "heavy": 3}
    light, heavy = fleet.types
    assert (light.energy.max_payload_kg, light.energy.speed_ms) == (1.0, 14.0)
    assert light.energy.battery_j == BASE.battery_j  # left out: the config's value
    assert (heavy.energy.max_payload_kg, heavy.energy.battery_j) == (4.0, 400000.0)
    models = fleet.models()
    assert models[0] is models[1] and models[2] is models[3] is models[4]
    assert models[0] is not models[2]
    assert models[2].usable_j == pytest.approx(400000.0 * 0.75, rel=1e-12)
    described = fleet.describe(BASE)
    assert described["types"]["light"] == {"max_payload_kg": 1.0, "speed_ms": 14.0}


def test_json_drones_with_types_and_plain_depot_lists(tmp_path, depots):
    doc = {
        "types": {"a": {"max_payload_kg": 1.5}, "b": {}},
        "drones": [{"depot": 2, "type": "b"}, {"depot": 0, "type": "a"}],
    }
    fleet = load_fleet(_write(tmp_path, "f.json", json.dumps(doc)), depots, 8, BASE)
    assert fleet.depot.tolist() == [2, 0] and fleet.type_names() == ["b", "a"]
    plain = load_fleet(_write(tmp_path, "p.json", "[2, 2, 1]"), depots, 8, BASE)
    assert plain.depot.tolist() == [2, 2, 1] and plain.type_names() == [DEFAULT_TYPE] * 3


@pytest.mark.parametrize(
    ("text", "column", "needle"),
    [
        ('{"counts": {"x": 2}}', "counts.x", "not among the types"),
        (
            '{"types": {"h": {"max_payload_kg": -1}}, "counts": {"h": 1}}',
            "types.h.max_payload_kg",
            "expected 0 < max_payload_kg ≤ 500, got -1",
        ),
        (
            '{"types": {"h": {"payload": 3}}, "counts": {"h": 1}}',
            "types.h.payload",
            "unknown key 'payload' in a drone type (expected some of: ",
        ),
        (
            '{"types": {"a": {}, "b": {}}, "drones": [{"depot": 0}]}',
            "drones[0].type",
            "several types",
        ),
        ('{"drones": [{"depot": 7}]}', "drones[0].depot", "ids 0..2"),
        ("[1, 99999999999999999999]", "drones[1].depot", "ids 0..2"),  # past int64
        ('{"drones": [{"depot": 1e300}]}', "drones[0].depot", "ids 0..2"),
        ('{"drones": [0], "counts": {"default": 1}}', None, "either"),
        ('{"counts": {"default": 2.5}}', "counts.default", "whole number"),
        ('{"counts": {"default": 0}}', None, "no drones"),
        ('{"fleet": []}', "fleet", "unknown key"),
    ],
)
def test_bad_fleet_files_name_the_key(tmp_path, depots, text, column, needle):
    path = _write(tmp_path, "bad.json", text)
    with pytest.raises(InputError) as err:
        load_fleet(path, depots, 8, BASE)
    assert err.value.file == str(path) and err.value.column == column
    assert needle in err.value.message


def _big_types(n: int, used: int) -> str:
    """``n`` distinct types of the largest payload table (500 kg in steps of 0.1 g), the
    first ``used`` of them flown by one drone each."""
    types = "".join(
        f"[types.t{i}]\nmax_payload_kg = 500.0\ntable_step_kg = 0.0001\nbattery_j = {1e8 - i}\n"
        for i in range(n)
    )
    return types + "[counts]\n" + "".join(f"t{i} = 1\n" for i in range(used))


def test_types_whose_tables_would_fill_the_memory_are_refused_before_any_is_built(tmp_path, depots):
    """Each drone type has its own payload table, up to 5,000,001 entries: a fleet file
    of hundreds of such types took 116 MB and 0.6 s each before the first window. Only
    the types the drones fly count, and types of the same parameters share one table."""
    path = _write(tmp_path, "big.toml", _big_types(5, 5))
    with pytest.raises(InputError) as err:
        load_fleet(path, depots, 8, BASE)
    assert err.value.file == str(path) and err.value.column == "types"
    assert "5 drone types need payload tables of 25,000,005 entries" in err.value.message
    assert not any(json.loads(k)["table_step_kg"] == 0.0001 for k in EnergyModel._built)
    unused = load_fleet(_write(tmp_path, "unused.toml", _big_types(50, 3)), depots, 8, BASE)
    assert len(unused) == 3
    same = "[types.big]\nmax_payload_kg = 500.0\ntable_step_kg = 0.0001\n[counts]\nbig = 1000\n"
    assert len(load_fleet(_write(tmp_path, "same.toml", same), depots, 8, BASE)) == 1000


def test_uniform_fleet_is_one_default_type():
    f = Fleet.uniform(np.array([3, 1]), BASE)
    assert f.type_names() == [DEFAULT_TYPE, DEFAULT_TYPE] and len(f) == 2
    assert isinstance(f.models()[0], EnergyModel)


def _replay(example_csv: Path, out: Path, *extra: str) -> None:
    """One study square's day (a fleet file is one square's fleet)."""
    args = ["replay-day", "--area", "square", str(example_csv), "--date", "0811"]
    args += ["--out", str(out), "-q", *extra]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output


def test_mixed_fleet_day_keeps_every_drone_within_its_own_type(example_csv, tmp_path):
    """examples/fleet.toml: every route of the day within its own drone type's payload and
    battery, arrival times at its own speed, and the outputs record the types."""
    fleet_path = ROOT / "examples" / "fleet.toml"
    _replay(example_csv, tmp_path / "mixed", "--fleet", str(fleet_path))
    routes = pq.read_table(tmp_path / "mixed" / "routes.parquet").to_pydict()
    stops = pq.read_table(tmp_path / "mixed" / "stops.parquet").to_pydict()
    from marops_cli.sim.fleet import _FleetFile, _read, _types

    doc = _FleetFile.model_validate(_read(fleet_path))
    types = {t.name: t.energy for t in _types(doc, BASE, fleet_path)}
    assert set(routes["drone_type"]) == {"light", "heavy"}
    carried = {"light": 0.0, "heavy": 0.0}
    for kind, kg, e, frac in zip(
        routes["drone_type"],
        routes["payload_kg"],
        routes["energy_j"],
        routes["battery_frac"],
        strict=True,
    ):
        cfg = types[kind]
        assert kg <= cfg.max_payload_kg + 1e-9
        assert e <= cfg.battery_j * (1 - cfg.reserve) + 1e-6
        assert frac == pytest.approx(e / cfg.battery_j, rel=1e-12)
        carried[kind] = max(carried[kind], kg)
    assert carried["heavy"] > types["light"].max_payload_kg  # the heavy ones carry more
    # Arrival times: each leg at its own drone's speed.
    kind_of = dict(zip(routes["drone"], routes["drone_type"], strict=False))
    for d, leg, arrive, seq in zip(
        stops["drone"], stops["leg_m"], stops["arrive_s"], stops["seq"], strict=True
    ):
        if seq == 1:  # the first customer: one leg from the start
            assert arrive == pytest.approx(leg / types[kind_of[d]].speed_ms, rel=1e-12)
    metrics = json.loads((tmp_path / "mixed" / "metrics.json").read_text())
    assert metrics["days"][0]["drone_types"] == {"light": 4, "heavy": 4}
    assert metrics["meta"]["settings"]["fleet"]["types"]["light"]["max_payload_kg"] == 1.0


def test_one_type_fleet_file_writes_the_default_runs_bytes(example_csv, tmp_path):
    """A fleet file that gives the default fleet changes nothing: the route files are
    byte-identical and the day's metrics equal, bar the wall time."""
    _replay(example_csv, tmp_path / "plain")
    fleet = _write(tmp_path, "one.json", '{"counts": {"default": 8}}')
    _replay(example_csv, tmp_path / "file", "--fleet", str(fleet))
    for name in ("stops.parquet", "routes.parquet"):
        assert (tmp_path / "plain" / name).read_bytes() == (tmp_path / "file" / name).read_bytes()
    a, b = (json.loads((tmp_path / f / "metrics.json").read_text()) for f in ("plain", "file"))
    for doc in (a, b):
        for day in doc["days"]:
            day.pop("runtime_s")
            day["solver"].pop("solve_s")
    assert a["days"] == b["days"] and a["meta"]["settings"] == b["meta"]["settings"]
