"""Sweeps on a Dask cluster and the jobs dataset: the same files however the jobs ran
(one process, a LocalCluster, two sessions with a kill -9 between), a folder of another
run refused, and one line when distributed is missing (README.md "Sweeps on a cluster")."""

from __future__ import annotations

import csv
import http.server
import io
import logging
import shutil
import signal
import socketserver
import subprocess
import sys
import threading
from pathlib import Path

import pyarrow as pa
import pyarrow.dataset as ds
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app

RUNNER = CliRunner()
# Results don't depend on --workers or --scheduler: all these runs share one identity.
ARGS = ["--methods", "stay,greedy", "--dates", "0811,0812", "--no-plot"]
N_JOBS = 4
WALL_TIME = ("runtime_s", "solver_solve_s")  # docs/outputs.md: wall time, differs per run
MAIN = "from marops_cli.cli.app import main; main()"


def _evaluate(example_csv: Path, out: Path, *extra: str) -> list[str]:
    return ["evaluate", "--area", "square", str(example_csv), *ARGS, *extra, "--out", str(out)]


def _subprocess(args: list[str]) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-c", MAIN, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group: workers are killed with it
    )


def _same_outputs(a: Path, b: Path) -> None:
    """results.parquet, summary.csv and summary.md the same, but for wall times."""
    ra, rb = pq.read_table(a / "results.parquet"), pq.read_table(b / "results.parquet")
    assert ra.schema.equals(rb.schema, check_metadata=True)  # columns, types, metadata
    assert ra.drop_columns(list(WALL_TIME)).equals(rb.drop_columns(list(WALL_TIME)))

    def csv_rows(p: Path) -> list[dict[str, str]]:
        rows = list(csv.DictReader(io.StringIO((p / "summary.csv").read_text())))
        return [{k: v for k, v in r.items() if not k.startswith("runtime_s_")} for r in rows]

    assert csv_rows(a) == csv_rows(b) and len(csv_rows(a)) == 2

    def md(p: Path) -> list[str]:
        lines = (p / "summary.md").read_text().splitlines()
        return [line for line in lines if not line.startswith("| Average running time")]

    assert md(a) == md(b)


@pytest.fixture(scope="module")
def one_worker(example_csv: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("one") / "ev"
    res = RUNNER.invoke(app, _evaluate(example_csv, out, "--workers", "1"))
    assert res.exit_code == 0, res.output
    return out


def test_one_file_per_job_in_a_partitioned_dataset(one_worker: Path) -> None:
    files = sorted(p.relative_to(one_worker).as_posix() for p in one_worker.rglob("*.parquet"))
    assert files == [
        "jobs/hub=0/method=greedy/day=2022-08-11/s0-r0.parquet",
        "jobs/hub=0/method=greedy/day=2022-08-12/s0-r0.parquet",
        "jobs/hub=0/method=stay/day=2022-08-11/s0-r0.parquet",
        "jobs/hub=0/method=stay/day=2022-08-12/s0-r0.parquet",
        "results.parquet",
    ]
    # The partition keys typed as results.parquet types them (docs/outputs.md).
    keys = pa.schema([("hub", pa.int64()), ("method", pa.string()), ("day", pa.date32())])
    jobs = ds.dataset(
        one_worker / "jobs", format="parquet", partitioning=ds.partitioning(keys, flavor="hive")
    ).to_table()
    results = pq.read_table(one_worker / "results.parquet")
    assert jobs.num_rows == results.num_rows == N_JOBS
    got = sorted(
        zip(*(jobs.column(c).to_pylist() for c in ("method", "day", "delivered")), strict=True)
    )
    want = sorted(
        zip(*(results.column(c).to_pylist() for c in ("method", "day", "delivered")), strict=True)
    )
    assert got == want and set(jobs.column("hub").to_pylist()) == {0}


def test_local_cluster_writes_what_one_worker_writes(
    example_csv: Path, one_worker: Path, tmp_path: Path
) -> None:
    out = tmp_path / "ev"
    proc = _subprocess(_evaluate(example_csv, out, "--scheduler", "local", "--workers", "2"))
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert "local Dask cluster of 2 workers" in err and "Traceback" not in err
    _same_outputs(one_worker, out)


def test_killed_run_resumes_without_rerunning_finished_jobs(
    example_csv: Path, one_worker: Path, tmp_path: Path, stop_marops
) -> None:
    out = tmp_path / "ev"
    args = _evaluate(example_csv, out, "--workers", "1")
    stop_marops(args, lambda: any((out / "jobs").rglob("*.parquet")), signal.SIGKILL)
    before = {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in (out / "jobs").rglob("*.parquet")}
    assert 1 <= len(before) < N_JOBS and not (out / "results.parquet").exists()
    res = RUNNER.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert f"resumed: {len(before)} of {N_JOBS} replays" in res.stderr
    for p, stamp in before.items():  # the finished jobs were not run again
        assert (p.stat().st_ino, p.stat().st_mtime_ns) == stamp, p
    assert len(list((out / "jobs").rglob("*.parquet"))) == N_JOBS
    _same_outputs(one_worker, out)


def test_a_folder_of_another_run_is_refused_then_force_clears_it(
    example_csv: Path, one_worker: Path, tmp_path: Path, fails_cleanly
) -> None:
    out = tmp_path / "ev"
    shutil.copytree(one_worker, out)
    other = ["evaluate", "--area", "square", str(example_csv), "--methods", "stay"]
    other += ["--dates", "0811", "--no-plot", "--workers", "1", "-q", "--out", str(out)]
    fails_cleanly(other, tmp_path, str(out / "jobs"), "other settings", "--force")
    res = RUNNER.invoke(app, [*other, "--force"])
    assert res.exit_code == 0, res.output
    files = [p.relative_to(out / "jobs").as_posix() for p in (out / "jobs").rglob("*.parquet")]
    assert files == ["hub=0/method=stay/day=2022-08-11/s0-r0.parquet"]


def test_scheduler_without_distributed_says_how_to_install_it(
    example_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fails_cleanly
) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed fails
    args = _evaluate(example_csv, tmp_path / "ev", "--scheduler", "local")
    fails_cleanly(args, tmp_path, "--scheduler", "pip install 'marops[cluster]'")


def test_unreachable_scheduler_is_one_line_and_writes_nothing(
    example_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fails_cleanly
) -> None:
    from marops_cli.workers import cluster

    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 1)
    args = _evaluate(example_csv, tmp_path / "ev", "--scheduler", "tcp://127.0.0.1:9", "-q")
    fails_cleanly(args, tmp_path, "--scheduler tcp://127.0.0.1:9", "no Dask scheduler answered")
    assert not (tmp_path / "ev").exists()


@pytest.mark.parametrize(
    ("address", "why"),
    [
        ("tcp://host:notaport", "invalid literal for int()"),
        ("foo://host:8786", "unknown address scheme 'foo'"),
        ("host", "missing port number"),
    ],
)
@pytest.mark.parametrize("command", ["evaluate", "replay-day"])
def test_a_scheduler_that_is_no_address_is_refused_before_the_data_is_read(
    example_csv: Path, tmp_path: Path, fails_cleanly, address: str, why: str, command: str
) -> None:
    """An address Dask cannot connect to by its form alone was refused only as the jobs
    were handed out, after the data was read (its lines printed before the error)."""
    pytest.importorskip("distributed")
    if command == "evaluate":
        args = _evaluate(example_csv, tmp_path / "ev", "--scheduler", address)
    else:
        args = ["replay-day", "--area", "square", str(example_csv), "--dates", "0811,0812"]
        args += ["--scheduler", address, "--out", str(tmp_path / "ev")]
    line = fails_cleanly(args, tmp_path, f"--scheduler {address}: not a scheduler address")
    assert why in line
    assert not (tmp_path / "ev").exists()


class _Silent(socketserver.BaseRequestHandler):
    """Waits for a request, as a web server does."""

    def handle(self) -> None:
        self.request.recv(1 << 16)
        self.request.sendall(b"HTTP/1.0 400 Bad request\r\n\r\n")


class _Banner(socketserver.BaseRequestHandler):
    """Speaks first, but not Dask (SSH, SMTP and the like)."""

    def handle(self) -> None:
        self.request.sendall(b"SSH-2.0-OpenSSH_9.6\r\n")


@pytest.mark.parametrize("handler", [http.server.SimpleHTTPRequestHandler, _Silent, _Banner])
def test_a_scheduler_address_that_is_no_dask_scheduler_is_one_line_in_time(
    example_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fails_cleanly, handler
) -> None:
    """A web server (or anything else) at --scheduler: refused within the connect
    timeout, nothing allocated from its answer, nothing written."""
    pytest.importorskip("distributed")
    from marops_cli.workers import cluster

    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 1)
    server = socketserver.ThreadingTCPServer(("127.0.0.1", 0), handler)
    server.daemon_threads = True
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        address = f"tcp://127.0.0.1:{server.server_address[1]}"
        args = _evaluate(example_csv, tmp_path / "ev", "--scheduler", address, "-q")
        fails_cleanly(args, tmp_path, f"--scheduler {address}", "not a Dask scheduler")
    finally:
        server.shutdown()
        server.server_close()
    assert not (tmp_path / "ev").exists()


def test_a_dask_scheduler_passes_the_probe() -> None:
    distributed = pytest.importorskip("distributed")
    from marops_cli.workers.cluster import _probe

    with distributed.LocalCluster(
        n_workers=0, processes=False, dashboard_address=None, silence_logs=50
    ) as c:
        _probe(c.scheduler_address)  # no error


def test_a_worker_with_another_actor_refuses_to_run(
    example_csv: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A machine whose trained actor differs from the one evaluate resolved would give
    other rows under the same run identity: its jobs fail with one line instead."""
    import datetime as dt

    from marops_cli.config import PlannerConfig
    from marops_cli.data.reader import sha256_file
    from marops_cli.evaluate import expand_settings, prepare
    from marops_cli.evaluate.runner import EvaluateWork
    from marops_cli.workers import cluster

    monkeypatch.setattr(cluster, "one_thread", lambda: None)  # this process is no worker

    cfg = PlannerConfig()
    day = [dt.date(2022, 8, 11)]
    prep = prepare(example_csv, cfg, ["marops"], expand_settings(cfg), days=day)
    wrong = EvaluateWork(prep, {"marops": "0" * 64})
    index, metrics, error, code = cluster._cluster_job(prep.jobs[0], wrong)
    assert metrics is None and code == 2
    assert error is not None and "another trained actor for marops" in error
    right = EvaluateWork.of(prep)
    assert list(right.actors) == ["marops"]
    assert right.actors["marops"] == sha256_file(prep.actor_files["marops"])
    index, metrics, error, code = cluster._cluster_job(prep.jobs[0], right)
    assert error is None and metrics is not None and metrics["requests"] > 0


def test_replay_days_on_a_local_cluster_are_the_days_planned_here(
    example_csv: Path, tmp_path: Path
) -> None:
    """``replay-day --dates --scheduler local``: each day planned on a Dask worker and
    written by the command, the same route files as one process planning them."""
    base = ["replay-day", "--area", "square", str(example_csv), "--dates", "0811..0812"]
    base += ["--method", "greedy"]
    here = tmp_path / "here"
    res = RUNNER.invoke(app, [*base, "--workers", "1", "--out", str(here)])
    assert res.exit_code == 0, res.output
    out = tmp_path / "cluster"
    proc = _subprocess([*base, "--scheduler", "local", "--workers", "2", "--out", str(out)])
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert "2 days to replay on a local Dask cluster" in err and "Traceback" not in err
    for day in ("2022-08-11", "2022-08-12"):
        for name in ("stops.parquet", "routes.parquet"):
            assert (here / day / name).read_bytes() == (out / day / name).read_bytes()


def test_a_replay_worker_with_another_actor_refuses_to_run() -> None:
    """replay-day's day work checks the actor the same way (sim.scenario.other_actor)."""
    from marops_cli.data.reader import sha256_file
    from marops_cli.methods import method
    from marops_cli.policies.registry import default_policy_path
    from marops_cli.sim.days import ReplayWork

    actor = default_policy_path()
    assert actor is not None
    work = ReplayWork({}, "marops", None, 0, False, method("marops"), "0" * 64)
    problem = work.refuse()
    assert problem is not None and "another trained actor for marops" in problem
    work = ReplayWork({}, "marops", None, 0, False, method("marops"), sha256_file(actor))
    assert work.refuse() is None
    assert ReplayWork({}, "myopic", None, 0, False, method("myopic")).refuse() is None


def test_a_task_of_the_local_scheduler_cut_short_prints_no_traceback(caplog) -> None:
    """Ctrl-C while the work was scattered to a local cluster's workers left a scheduler
    task failed (KeyError of a worker gone) that asyncio logged as 'Task exception was
    never retrieved' with its traceback, above marops's one line."""
    pytest.importorskip("distributed")
    import time

    from marops_cli.workers.cluster import connect

    async def cut_short() -> None:
        raise KeyError("tls://127.0.0.1:43953")

    with connect("local", 1) as client:
        loop = client.loop.asyncio_loop
        loop.call_soon_threadsafe(lambda: loop.create_task(cut_short()) and None)
        time.sleep(0.5)
    assert "never retrieved" not in caplog.text
    assert logging.getLogger("asyncio").level == logging.NOTSET  # as it was
