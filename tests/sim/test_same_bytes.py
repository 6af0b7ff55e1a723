"""The same command gives the same bytes whatever the thread count and working folder."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import pytest


def _marops(args: list[str], cwd: Path, threads: int) -> None:
    """Run ``marops ARGS`` in ``cwd`` in a fresh process with ``threads`` OpenMP/BLAS threads."""
    env = dict(os.environ)
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        env[var] = str(threads)
    code = "from marops_cli.cli.app import main; main()"
    res = subprocess.run(
        [sys.executable, "-c", code, *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr


PAPER_OPS = Path(__file__).resolve().parents[2] / "examples" / "paper-ops.toml"


def _replay(example_csv: Path, cwd: Path, threads: int, method: str) -> dict[str, str]:
    args = ["replay-day", "--area", "square", str(example_csv), "--date", "0811"]
    args += ["--method", method, "-q"]
    if method == "mappo":  # its actor flies the paper's operating model only
        args += ["--config", str(PAPER_OPS)]
    _marops([*args, "--out", "out"], cwd, threads)
    return {
        name: hashlib.sha256((cwd / "out" / name).read_bytes()).hexdigest()
        for name in ("stops.parquet", "routes.parquet")
    }


@pytest.mark.parametrize("method", ["stay", "marops"])
def test_replay_bytes_do_not_depend_on_threads_or_folders(
    example_csv: Path, tmp_path: Path, method: str
) -> None:
    """k-means' centroids used to move in their last bits with OMP_NUM_THREADS."""
    runs = []
    for i, threads in enumerate((1, 2, 4)):
        cwd = tmp_path / f"run{i}" / "nested"  # another working folder each time
        cwd.mkdir(parents=True)
        runs.append(_replay(example_csv, cwd, threads, method))
    assert runs[0] == runs[1] == runs[2]


def test_a_city_s_bytes_do_not_depend_on_threads_or_folders(example_csv: Path, tmp_path: Path):
    """The default run over the hubs it places: every hub's route files the same bytes
    with one thread and with four, from different folders."""
    runs = []
    for threads in (1, 4):
        cwd = _fresh(tmp_path / f"city{threads}" / "nested")
        args = ["replay-day", str(example_csv), "--date", "0811", "--method", "stay", "-q"]
        _marops([*args, "--out", "out"], cwd, threads)
        files = sorted((cwd / "out").glob("hub-*/*.parquet"))
        runs.append(
            {
                p.relative_to(cwd).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
                for p in files
            }
        )
    assert len(runs[0]) > 2 and runs[0] == runs[1]


def test_every_method_and_evaluate_same_on_1_and_4_threads(example_csv: Path, tmp_path: Path):
    """Every method's route files, and evaluate's rows (less its wall times), are the
    same with one thread and with four, run from different folders."""
    import pyarrow.parquet as pq

    from marops_cli.sim.scenario import METHODS

    for method in METHODS:
        a = _replay(example_csv, _fresh(tmp_path / f"{method}1" / "x"), 1, method)
        b = _replay(example_csv, _fresh(tmp_path / f"{method}4"), 4, method)
        assert a == b, method
    rows = []
    for threads in (1, 4):
        cwd = _fresh(tmp_path / f"ev{threads}")
        args = ["evaluate", "--area", "square", str(example_csv), "--methods", "stay,greedy,marops"]
        args += ["--dates"]
        _marops([*args, "0811", "--workers", "2", "--no-plot", "--out", "ev", "-q"], cwd, threads)
        table = pq.read_table(cwd / "ev" / "results.parquet")
        keep = [c for c in table.column_names if c not in ("runtime_s", "solver_solve_s")]
        rows.append(table.select(keep).replace_schema_metadata(None))
    assert rows[0].equals(rows[1])


def _fresh(path: Path) -> Path:
    path.mkdir(parents=True)
    return path
