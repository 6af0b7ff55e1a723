"""End to end: replay a day of the example for each method and check every invariant."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.config import DataConfig, EnergyConfig
from marops_cli.data.prepare import prepare_day
from marops_cli.data.reader import read_lade
from marops_cli.energy import reference_power_w
from marops_cli.segment import Depots
from marops_cli.sim.metrics import gini

runner = CliRunner()
DAY = "2022-08-11"
METHODS = [
    "stay",
    "ops-random",
    "greedy",
    "ops-global",
    "backlog",
    "rebalance",
    "marops",
    "squares",
    "mappo",
]
SEGMENTATION = {"squares": "squares"}  # the rest replay on k-means depots
PAPER_OPS = Path(__file__).resolve().parents[2] / "examples" / "paper-ops.toml"
CONFIG = {"mappo": ["--config", str(PAPER_OPS)]}
"""mappo's actor flies the paper's operating model only; the rest the default (realistic)."""


@pytest.fixture(scope="module")
def depots_files(example_csv: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    out = {}
    for seg in ("kmeans", "squares"):
        path = tmp_path_factory.mktemp("seg") / f"{seg}.json"
        res = runner.invoke(
            app,
            [
                "segment",
                str(example_csv),
                "--dates",
                "0801..0810",
                "--method",
                seg,
                "--out",
                str(path),
            ],
        )
        assert res.exit_code == 0, res.output
        out[seg] = path
    return out


@pytest.fixture(scope="module")
def depots_file(depots_files: dict[str, Path]) -> Path:
    return depots_files["kmeans"]


def _depots_of(depots_files: dict[str, Path], method: str) -> Path:
    return depots_files[SEGMENTATION.get(method, "kmeans")]


@pytest.fixture(scope="module")
def replays(example_csv: Path, depots_files, tmp_path_factory: pytest.TempPathFactory):
    outs = {}
    for method in METHODS:
        out = tmp_path_factory.mktemp(method)
        res = runner.invoke(
            app,
            [
                "replay-day",
                str(example_csv),
                "--date",
                "0811",
                "--depots",
                str(_depots_of(depots_files, method)),
                "--method",
                method,
                "--out",
                str(out),
                *CONFIG.get(method, []),
            ],
        )
        assert res.exit_code == 0, res.output
        outs[method] = out
    return outs


def _reference_energy(leg_m: np.ndarray, payload: np.ndarray) -> np.ndarray:
    """Leg energy with the exact (root-finding) model, no lookup table."""
    cfg = EnergyConfig()
    cache: dict[float, float] = {}
    out = np.zeros(leg_m.size)
    for i, (d, w) in enumerate(zip(leg_m, payload, strict=True)):
        key = round(float(w), 9)
        if key not in cache:
            cache[key] = reference_power_w(key, cfg)
        out[i] = cache[key] * d / cfg.speed_ms
    return out


@pytest.mark.parametrize("method", METHODS)
def test_every_window_respects_the_rules(replays, depots_files, method: str) -> None:
    depots_file = _depots_of(depots_files, method)
    st = pq.read_table(replays[method] / "stops.parquet").to_pydict()
    rt = pq.read_table(replays[method] / "routes.parquet").to_pydict()
    depots = json.loads(depots_file.read_text())
    cands = {int(k): v for k, v in depots["candidates"].items()}
    ecfg = EnergyConfig()
    n_routes = len(rt["drone"])
    assert n_routes == 8 * 16  # one row per drone and window
    keys = list(zip(st["window"], st["drone"], strict=True))
    seq = np.array(st["seq"])
    leg_m, leg_j = np.array(st["leg_m"]), np.array(st["leg_j"])
    prev_end: dict[int, int] = {}
    for i in range(n_routes):
        w, u = rt["window"][i], rt["drone"][i]
        rows = [j for j, k in enumerate(keys) if k == (w, u)]
        rows.sort(key=lambda j: seq[j])
        kinds = [st["kind"][j] for j in rows]
        assert kinds[0] == "start" and kinds[-1] == "end"
        assert set(kinds[1:-1]) <= {"customer"}
        assert st["depot"][rows[0]] == rt["start_depot"][i]
        assert st["depot"][rows[-1]] == rt["end_depot"][i]
        if u in prev_end:  # a drone starts where it ended the window before
            assert rt["start_depot"][i] == prev_end[u]
        prev_end[u] = rt["end_depot"][i]
        if method != "ops-global" and rt["action"][i] != -1:
            assert rt["end_depot"][i] == cands[rt["start_depot"][i]][rt["action"][i]]
        elif len(rows) == 2:  # free landing (action -1) with nothing to carry: it stays
            assert rt["end_depot"][i] == rt["start_depot"][i]
        payload = np.array([st["payload_kg"][j] for j in rows])
        assert payload[0] <= ecfg.max_payload_kg + 1e-9
        assert_allclose(payload[0], rt["payload_kg"][i], atol=1e-9)
        legs = leg_j[rows]
        assert_allclose(legs.sum(), rt["energy_j"][i], rtol=1e-9, atol=1e-6)
        assert rt["energy_j"][i] <= ecfg.usable_j + 1e-6
        # Energy recomputed from the stops with the exact model: within 0.1 %.
        ref = _reference_energy(leg_m[rows][1:], payload[:-1])
        assert_allclose(legs[1:], ref, rtol=1e-3, atol=1e-6)


@pytest.fixture(scope="module")
def day_requests(example_csv: Path, depots_files):
    table = read_lade(example_csv, DataConfig())
    out = {}
    for seg, path in depots_files.items():
        dep = Depots.load(path)
        out[seg] = dep, prepare_day(table, dep.frame, dt.date(2022, 8, 11), DataConfig())
    return out


@pytest.mark.parametrize("method", METHODS)
def test_day_accounting_and_metrics_recompute(replays, day_requests, method: str) -> None:
    dep, day = day_requests[SEGMENTATION.get(method, "kmeans")]
    st = pq.read_table(replays[method] / "stops.parquet").to_pydict()
    rt = pq.read_table(replays[method] / "routes.parquet").to_pydict()
    m = json.loads((replays[method] / "metrics.json").read_text())["days"][0]
    cust = [i for i, k in enumerate(st["kind"]) if k == "customer"]
    ids = [st["order_id"][i] for i in cust]
    assert len(ids) == len(set(ids)), "an order was delivered twice"
    assert m["requests"] == len(day)
    assert m["delivered"] == len(ids)
    assert m["delivered"] + m["undelivered"] == m["requests"]
    pos = {str(o): i for i, o in enumerate(day.order_id)}
    delay = np.array([(day.n_windows - w) * 0.5 for w in day.due_w])  # undelivered default
    early = []
    for i in cust:
        k = pos[st["order_id"][i]]
        w = st["window"][i]
        assert day.visible_w[k] <= w, "delivered before it was visible"
        assert st["due_window"][i] == day.due_w[k]
        assert st["delay_h"][i] == pytest.approx(max(0, w - day.due_w[k]) * 0.5)
        delay[k] = st["delay_h"][i]
        early.append(max(0.0, day.due_s[k] - (w * 1800 + st["arrive_s"][i])) / 3600)
    assert m["avg_delay_h"] == pytest.approx(delay.mean(), rel=1e-9)
    assert m["avg_early_h"] == pytest.approx(np.mean(early) if early else 0.0, rel=1e-9, abs=1e-12)
    area = dep.assign(day.x_m, day.y_m)
    per_area = np.bincount(area, weights=delay, minlength=len(dep))
    has = np.bincount(area, minlength=len(dep)) > 0
    assert m["delay_unfairness"] == pytest.approx(gini(per_area[has]), rel=1e-9)
    legs = np.array(st["leg_j"])
    assert m["mean_energy_kj"] == pytest.approx(legs.sum() / 8 / 1000, rel=1e-9)
    assert m["co2_g"] == pytest.approx(legs.sum() / 3.6e6 * 125, rel=1e-9)
    load = np.zeros(len(dep))
    for i, kind in enumerate(st["kind"]):
        if kind == "start":
            load[st["depot"][i]] += st["payload_kg"][i]
    assert_allclose([m["depot_load_kg"][str(d)] for d in range(len(dep))], load, atol=1e-5)
    frac = np.array(rt["battery_frac"])
    assert m["battery_frac_max"] == pytest.approx(frac.max(), rel=1e-9)
    assert m["solver"]["calls"] == 16


def test_metrics_json_holds_the_spec_columns(replays) -> None:
    """A day's record, flattened as the result tables flatten it, is the spec's columns
    in the spec's order (besides day, method, hub, the per-depot loads, the drones per
    type and the parcels left per depot), the operating model's after the day's under
    the realistic model, none of them under the paper's."""
    from marops_cli.evaluate.tables import flatten
    from marops_cli.sim.metrics import DAY_METRICS, OPS_METRICS

    per_key = ("depot_load_kg_", "drone_types_", "stock_left_")
    for method, specs in (("marops", (*DAY_METRICS, *OPS_METRICS)), ("mappo", DAY_METRICS)):
        m = json.loads((replays[method] / "metrics.json").read_text())["days"][0]
        cols = [k for k in flatten(m) if k not in ("day", "method", "hub")]
        kept = [k for k in cols if not k.startswith(per_key) or k in {s.name for s in specs}]
        assert kept == [s.name for s in specs], method


def test_gini_hand_values() -> None:
    assert gini(np.ones(5)) == pytest.approx(0.0)
    # One area holds all the delay among 4: G = (n - 1) / n = 0.75.
    assert gini(np.array([0.0, 0.0, 0.0, 8.0])) == pytest.approx(0.75)
    # [1, 3]: mean abs difference 2 over 2·mean 2·2 → |1-3|·2 / (2·2²·2) = 0.25.
    assert gini(np.array([1.0, 3.0])) == pytest.approx(0.25)


def _replay_0811(example_csv: Path, depots_file: Path, out: Path, *extra: str) -> Path:
    """``replay-day`` of 0811 on the k-means depots into ``out``, which must succeed."""
    args = ["replay-day", str(example_csv), "--date", "0811", "--depots", str(depots_file)]
    res = runner.invoke(app, [*args, *extra, "--out", str(out)])
    assert res.exit_code == 0, res.output
    return out


def test_same_seed_same_bytes(example_csv: Path, depots_file: Path, tmp_path: Path) -> None:
    extra = ("--method", "ops-random", "--seed", "3")
    outs = [_replay_0811(example_csv, depots_file, tmp_path / f"run{k}", *extra) for k in range(2)]
    for name in ("stops.parquet", "routes.parquet"):
        assert (outs[0] / name).read_bytes() == (outs[1] / name).read_bytes()


def test_cvxpy_and_direct_highs_plan_the_same_day(
    example_csv: Path, depots_file: Path, tmp_path: Path
) -> None:
    """``[plan] solver = "cvxpy"`` models the program the default hands HiGHS directly:
    a whole day's route files are the same bytes (docs/decisions.md, "Start-up and exit")."""
    outs = []
    for solver in ("highs", "cvxpy"):
        cfg = tmp_path / f"{solver}.toml"
        cfg.write_text(f'[plan]\nsolver = "{solver}"\n')
        extra = ("--method", "myopic", "--config", str(cfg))
        outs.append(_replay_0811(example_csv, depots_file, tmp_path / solver, *extra))
    for name in ("stops.parquet", "routes.parquet"):
        a, b = (pq.read_table(o / name) for o in outs)
        assert a.equals(b), name
