"""``marops evaluate`` end to end on the bundled example (2 held-out days, 2 methods, 2 α)."""

from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.config import PlannerConfig
from marops_cli.evaluate import evaluate_jobs, expand_settings, prepare
from marops_cli.evaluate.tables import KEY_COLUMNS, row_table, rows_table
from marops_cli.sim.metrics import METRICS

runner = CliRunner()
METHODS = ["ops-random", "greedy"]
ALPHAS = [0.3, 0.95]  # far apart: on two days a narrow gap can be swamped by dynamics
WALL_TIME = {"runtime_s", "solver_solve_s"}  # the only columns that may differ between runs


@pytest.fixture(scope="module")
def run_dir(example_csv: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("evaluate")
    args = ["evaluate", "--area", "square", str(example_csv), "--methods", ",".join(METHODS)]
    args += ["--split", "test"]
    args += ["--alpha", ",".join(map(str, ALPHAS)), "--workers", "2", "--out", str(out)]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert "Combined cost" in res.stdout  # the Table III print
    return out


def test_files_and_metadata(run_dir: Path) -> None:
    names = {p.name for p in run_dir.iterdir()}
    assert {"results.parquet", "summary.csv", "summary.md", "alpha.png", "unfairness.png"} <= names
    assert (run_dir / "actions.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "drones.png" not in names  # only swept flags get a figure
    assert not [n for n in names if n.endswith(".tmp")]
    table = pq.read_table(run_dir / "results.parquet")
    meta = json.loads(table.schema.metadata[b"marops"])
    assert meta["command"] == "evaluate"
    assert meta["methods"] == METHODS
    assert meta["days"] == ["2022-08-11", "2022-08-12"]  # last 20 % of 12 days
    assert meta["input"]["name"] == "shanghai_synth.csv"
    assert meta["swept"] == ["alpha"]


def test_one_row_per_day_method_setting_repeat(run_dir: Path) -> None:
    rows = pq.read_table(run_dir / "results.parquet").to_pylist()
    assert len(rows) == len(ALPHAS) * len(METHODS) * 2
    keys = {(r["alpha"], r["method"], r["day"], r["repeat"]) for r in rows}
    assert len(keys) == len(rows)
    for r in rows:
        assert r["drones"] == 8 and r["depots_n"] == 16 and r["seed"] == 0
        assert r["delivered"] + r["undelivered"] == r["requests"]
        assert sum(v for k, v in r.items() if k.startswith("depot_load_kg_")) > 0
        # Each row records its replay's wall time; how fast that is belongs to
        # benchmarks/evaluate.py, not to a test a busy machine could fail.
        assert math.isfinite(r["runtime_s"]) and r["runtime_s"] > 0


def _summary_csv(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as fh:
        return list(csv.DictReader(fh))


def test_results_recompute_to_summary(run_dir: Path) -> None:
    res = pq.read_table(run_dir / "results.parquet").to_pydict()
    summary = _summary_csv(run_dir / "summary.csv")
    assert len(summary) == len(ALPHAS) * len(METHODS)
    setting = np.array(res["setting"])
    method = np.array(res["method"])
    for s in set(setting.tolist()):
        # Combined cost from scratch: method means, normalised by the largest mean.
        means = {
            m: [
                np.mean(np.array(res[k])[(setting == s) & (method == m)])
                for k in ("mean_energy_kj", "avg_delay_h")
            ]
            for m in METHODS
        }
        top_e = max(v[0] for v in means.values())
        top_d = max(v[1] for v in means.values())
        for m in METHODS:
            row = next(r for r in summary if int(r["setting"]) == s and r["method"] == m)
            sel = (setting == s) & (method == m)
            assert int(row["n"]) == sel.sum()
            for k in ("mean_energy_kj", "avg_delay_h", "delay_unfairness", "delivered"):
                v = np.array(res[k], dtype=float)[sel]
                assert_allclose(float(row[f"{k}_mean"]), v.mean(), rtol=1e-12)
                assert_allclose(float(row[f"{k}_std"]), v.std(ddof=1), rtol=1e-12)
            cost = (means[m][0] / top_e + means[m][1] / top_d) / 2
            assert_allclose(float(row["combined_cost_mean"]), cost, rtol=1e-12)
            per_row = np.array(res["combined_cost"])[sel]
            assert_allclose(float(row["combined_cost_std"]), per_row.std(ddof=1), rtol=1e-12)


def test_workers_do_not_change_results(example_csv: Path, run_dir: Path) -> None:
    cfg = PlannerConfig()
    cfg.data.area = "square"
    prep = prepare(example_csv, cfg, METHODS, expand_settings(cfg, alpha=ALPHAS), split="test")
    one = evaluate_jobs(prep, workers=1).results
    two = pq.read_table(run_dir / "results.parquet")
    keep = [c for c in one.column_names if c not in WALL_TIME]
    assert one.column_names == two.column_names
    assert one.select(keep).to_pylist() == two.select(keep).to_pylist()


def test_alpha_trades_energy_for_delay(run_dir: Path) -> None:
    # The acceptance on the α sweep, per method: more α, less energy, more delay.
    summary = _summary_csv(run_dir / "summary.csv")
    for m in METHODS:
        rows = sorted((r for r in summary if r["method"] == m), key=lambda r: float(r["alpha"]))
        energy = [float(r["mean_energy_kj_mean"]) for r in rows]
        delay = [float(r["avg_delay_h_mean"]) for r in rows]
        assert energy[0] > energy[-1], (m, energy)
        assert delay[0] < delay[-1], (m, delay)


def test_a_single_day_leaves_the_std_empty(example_csv: Path, tmp_path: Path) -> None:
    """n = 1 has no spread: summary.csv leaves every ``_std`` cell empty (it wrote
    ``nan``, which reads as a failed metric) and keeps every mean; summary.md says n/a."""
    out = tmp_path / "one"
    args = ["evaluate", "--area", "square", str(example_csv), "--methods", "stay"]
    args += ["--dates", "0811"]
    res = runner.invoke(app, [*args, "--workers", "1", "--no-plot", "--out", str(out)])
    assert res.exit_code == 0, res.output
    (row,) = _summary_csv(out / "summary.csv")
    assert row["n"] == "1"
    stds = {k: v for k, v in row.items() if k.endswith("_std")}
    assert stds and set(stds.values()) == {""}, stds
    means = [v for k, v in row.items() if k.endswith("_mean")]
    assert all(math.isfinite(float(v)) for v in means)
    assert "nan" not in (out / "summary.csv").read_text()
    assert "± n/a" in (out / "summary.md").read_text()


def _documented_key_types() -> dict[str, pa.DataType]:
    """docs/outputs.md's "Column types" of results.parquet: the key columns' types."""
    text = (Path(__file__).resolve().parents[2] / "docs" / "outputs.md").read_text("utf-8")
    section = text.split("**Column types.**")[1].split("**Jobs dataset.**")[0]
    kinds = {"int64": pa.int64(), "float64": pa.float64(), "string": pa.string()}
    kinds["date32"] = pa.date32()
    out = {}
    for names, kind in re.findall(r"^\| (`[^|]+?) \| ([^|]+?) \|", section, flags=re.M):
        for name in re.findall(r"`(\w+)`", names):
            out[name] = kinds[kind.split(",")[0]]
    return out


def test_results_types_are_as_documented(run_dir: Path) -> None:
    """The key columns as docs/outputs.md types them; a count metric int64, any other
    float64; a job file's columns as results.parquet's."""
    documented = _documented_key_types()
    assert set(KEY_COLUMNS) <= documented.keys()
    schema = pq.read_schema(run_dir / "results.parquet")
    counts = ("solver_calls", "solver_fallbacks", "drone_types_", "stock_left_")
    for f in schema:
        if f.name in KEY_COLUMNS:
            want = documented[f.name]
        elif f.name in METRICS and METRICS[f.name].unit == "count" or f.name.startswith(counts):
            want = pa.int64()
        else:
            want = pa.float64()
        assert f.type == want, f.name
    job = next((run_dir / "jobs").rglob("*.parquet"))
    for f in pq.read_schema(job):
        assert schema.field(f.name).type == f.type, f.name


def test_a_metric_no_row_has_keeps_its_type() -> None:
    """charged_min is null on every day under unlimited swaps: the column stays int64
    (pandas reads it as numbers, not objects), as a float metric stays float64."""
    rows = [
        {"setting": 0, "method": m, "mean_energy_kj": 1.0, "avg_delay_h": 0.5, "co2_g": None}
        | {"charged_min": None}
        for m in ("a", "b")
    ]
    table = rows_table(rows)
    assert table.schema.field("charged_min").type == pa.int64()
    assert table.schema.field("co2_g").type == pa.float64()
    assert row_table(rows[0]).schema.field("charged_min").type == pa.int64()


def test_every_results_column_is_documented(run_dir: Path) -> None:
    """Each column of results.parquet is named in docs/outputs.md (a day metric, a key
    column, or a flattened one: ``solver_calls``, ``depot_load_kg_<depot>``, …)."""
    text = (Path(__file__).resolve().parents[2] / "docs" / "outputs.md").read_text("utf-8")
    named = set(re.findall(r"`(\w+)`", text))
    prefixes = tuple(re.findall(r"`(\w+_)<\w+>`", text))
    assert "depot_load_kg_" in prefixes and "stock_left_" in prefixes
    for name in pq.read_schema(run_dir / "results.parquet").names:
        assert name in named or name.startswith(prefixes), name
