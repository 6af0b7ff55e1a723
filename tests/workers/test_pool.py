"""The worker pool behind evaluate, replay-day and training: results in job order
whatever the number of workers, each worker set up once, failures as one line, and the
one-thread limit that training takes back (docs/decisions.md, "Workers")."""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from marops_cli.errors import InputError, RunError
from marops_cli.workers import LocalPool, outcomes, single_threaded

ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Square:
    index: int
    x: int


@dataclass
class SquareWork:
    """Squares its jobs' numbers; 13 is bad input, 666 a failed run."""

    setups: int = 0
    preload = ()

    def setup(self) -> None:
        self.setups += 1

    def run(self, job: Square) -> tuple[int, int, int]:
        if job.x == 13:
            raise InputError("13 is unlucky", file="numbers.txt")
        if job.x == 666:
            raise RunError("the run broke")
        return job.x * job.x, os.getpid(), self.setups

    def refuse(self) -> str | None:
        return None


@pytest.fixture(autouse=True)
def _importable(monkeypatch: pytest.MonkeyPatch) -> None:
    """Workers unpickle this module's work by name: they get the parent's sys.path."""
    monkeypatch.syspath_prepend(str(ROOT))


@pytest.mark.parametrize("workers", [1, 2])
def test_results_come_back_in_job_order(workers: int) -> None:
    jobs = [Square(i, x) for i, x in enumerate([5, 3, 9, 1, 7, 2])]
    with LocalPool(SquareWork(), workers) as pool:
        got = pool.results(jobs)
        again = pool.results(jobs[::-1])
    assert [square for square, _, _ in got] == [25, 9, 81, 1, 49, 4]
    assert [square for square, _, _ in again] == [4, 49, 1, 81, 9, 25]
    assert {setups for _, _, setups in got + again} == {1}  # once per process
    pids = {pid for _, pid, _ in got + again}
    assert (pids == {os.getpid()}) == (workers == 1)


@pytest.mark.parametrize("workers", [1, 2])
def test_a_failed_job_is_raised_as_one_line(workers: int) -> None:
    with LocalPool(SquareWork(), workers) as pool:
        with pytest.raises(InputError, match=r"^numbers.txt: 13 is unlucky$"):
            pool.results([Square(0, 2), Square(1, 13)])
        with pytest.raises(RunError, match=r"^the run broke$"):
            pool.results([Square(0, 666)])


_KILLED_WORKERS = """
import os, signal, sys
sys.path[:0] = [{root!r}]
from tests.workers.test_pool import Square, SquareWork
from marops_cli.workers.pool import LocalPool

if __name__ == "__main__":
    try:
        with LocalPool(SquareWork(), 2) as pool:
            assert [r[0] for r in pool.results([Square(0, 2), Square(1, 3)])] == [4, 9]
            procs = list(pool._pool._pool)
            for proc in procs:  # as a SIGTERM to the process group kills the idle workers
                os.kill(proc.pid, signal.SIGTERM)
            for proc in procs:
                proc.join()
            raise KeyboardInterrupt  # as the signal stops this process's work
    except KeyboardInterrupt:
        print("stopped", all(proc.exitcode is not None for proc in procs))
"""


def test_workers_killed_from_outside_do_not_hang_the_stop(tmp_path: Path) -> None:
    """Idle workers hold the job queue's read lock while they wait; one killed there by a
    SIGTERM to the whole process group (``timeout``, ``kill -- -PGID``, systemd) left it
    held, and stopping the pool waited on it for ever. The pool now stops, and so does
    the process (its exit does not wait on the pool either). ``timeout`` only ends a
    hang."""
    script = tmp_path / "killed.py"
    script.write_text(_KILLED_WORKERS.format(root=str(ROOT)))
    res = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "stopped True"
    assert "Traceback" not in res.stderr


def test_outcomes_hold_every_job_once() -> None:
    jobs = [Square(i, i) for i in range(5)]
    with outcomes(SquareWork(), jobs, 2, None, "squares") as done:
        found = sorted((o.index, o.value()[0]) for o in done)
    assert found == [(i, i * i) for i in range(5)]
    with outcomes(SquareWork(), [], 2, None, "squares") as done:
        assert list(done) == []


class _FakeContext:
    """A multiprocessing context whose pool start is pressed Ctrl-C half-way."""

    def __init__(self) -> None:
        self.started = self.stopped = False

    def get_start_method(self) -> str:
        return "fake"

    def Pool(self, *args: object, **kwargs: object) -> _FakeContext:  # noqa: N802
        import signal

        signal.raise_signal(signal.SIGINT)  # Ctrl-C while the workers start
        self.started = True  # the start went on to its end
        return self

    def terminate(self) -> None:
        self.stopped = True

    def join(self) -> None:
        pass


def test_ctrl_c_while_workers_start_waits_for_the_start_then_stops_them(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Ctrl-C that arrives while the workers are handed their start-up data is held
    until they have it (a half-sent one made a worker print ``pickle data was
    truncated``); then it interrupts as ever, and the workers are stopped."""
    import signal

    from marops_cli.workers import pool

    fake = _FakeContext()
    monkeypatch.setattr(pool, "_context", lambda: fake)
    # Python's own Ctrl-C handling, whatever an earlier test left (a shell command run
    # by os.system, as a hostile actor file's, can leave SIGINT ignored).
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        before = signal.getsignal(signal.SIGINT)
        with pytest.raises(KeyboardInterrupt):
            LocalPool(SquareWork(), 2)
        assert fake.started and fake.stopped
        assert signal.getsignal(signal.SIGINT) is before
    finally:
        signal.signal(signal.SIGINT, old)


def test_ctrl_c_while_the_fork_server_imports_is_one_interruption(tmp_path: Path) -> None:
    """Ctrl-C reaches the whole process group, the fork server too, which imports a
    work's modules as it starts: it ignores it (its traceback followed "marops:
    interrupted"), and so do the workers it forks; the parent is interrupted once and
    stops them."""
    import signal
    import subprocess
    import sys
    import time

    ready, go = tmp_path / "ready", tmp_path / "go"
    script = (
        "import signal, sys\n"
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "from marops_cli.workers import LocalPool\n"
        "from tests.workers.test_pool import GatedWork, Square\n"
        "try:\n"
        "    with LocalPool(GatedWork(), 2) as pool:\n"
        "        pool.results([Square(i, i) for i in range(4)])\n"
        "except KeyboardInterrupt:\n"
        "    sys.stderr.write('interrupted\\n')\n"
        "    sys.exit(130)\n"
        "sys.exit(0)\n"
    )
    env = {**os.environ, "MAROPS_TEST_GATE_READY": str(ready), "MAROPS_TEST_GATE_GO": str(go)}
    proc = subprocess.Popen(
        [sys.executable, "-c", script],
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, like a terminal's
    )
    deadline = time.monotonic() + 120
    while not ready.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    assert ready.exists(), proc.communicate(timeout=60)
    os.killpg(proc.pid, signal.SIGINT)  # while the fork server imports the gate
    time.sleep(0.2)  # (delivered before the gate opens; no assertion rests on it)
    go.write_text("go")
    _, err = proc.communicate(timeout=120)
    assert ready.read_text() == "ignored"  # the server started with SIGINT ignored
    assert (proc.returncode, err) == (130, "interrupted\n"), err


@dataclass
class GatedWork(SquareWork):
    """Squares, with the gate among the fork server's imports."""

    preload = ("tests.workers._sigint_gate",)


def test_one_thread_is_taken_back() -> None:
    torch = pytest.importorskip("torch")
    torch.set_num_threads(2)
    before = (torch.get_num_threads(), os.environ.get("OMP_NUM_THREADS"))
    strict = torch.are_deterministic_algorithms_enabled()
    with single_threaded(deterministic=True):
        assert torch.get_num_threads() == 1 and os.environ["OMP_NUM_THREADS"] == "1"
        assert torch.are_deterministic_algorithms_enabled()
    assert (torch.get_num_threads(), os.environ.get("OMP_NUM_THREADS")) == before
    assert torch.are_deterministic_algorithms_enabled() == strict


def _main(monkeypatch: pytest.MonkeyPatch, **attrs: object) -> None:
    """This process's ``__main__`` as a notebook or ``python - < script.py`` has it."""
    import sys
    import types

    main = types.ModuleType("__main__")
    main.__spec__ = None
    for k, v in attrs.items():
        setattr(main, k, v)
    monkeypatch.setitem(sys.modules, "__main__", main)


def test_workers_start_under_a_main_without_a_file(monkeypatch: pytest.MonkeyPatch) -> None:
    # A notebook's (or `python -c`'s) main has no file: workers import nothing of it.
    _main(monkeypatch)
    with LocalPool(SquareWork(), 2) as pool:
        assert [square for square, _, _ in pool.results([Square(0, 3)])] == [9]


def test_a_script_read_from_stdin_stops_before_its_workers_start(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Each worker imports the main script by its path, which `<stdin>` is not, guard or
    # not: the reason, not "Broken pipe" and advice to add the guard the script has.
    _main(monkeypatch, __file__="<stdin>")
    with pytest.raises(RunError, match=r"^the script that started marops \(<stdin>\) is no file"):
        LocalPool(SquareWork(), 2)
    with LocalPool(SquareWork(), 1) as pool:  # one worker: this process, as before
        assert [square for square, _, _ in pool.results([Square(0, 3)])] == [9]


def test_torch_blas_runs_the_code_path_of_every_processor(monkeypatch: pytest.MonkeyPatch) -> None:
    """MKL's kernels are pinned to the path every x86 processor runs alike (a trained
    actor's weights the same bytes on any machine), unless the user chose one; the
    command line and ``import marops_cli`` do it before anything computes, and never
    once torch is loaded (set then, it would reach the workers only)."""
    import subprocess
    import sys

    monkeypatch.delenv("MKL_CBWR", raising=False)

    def mkl_cbwr(code: str) -> str:
        probe = f"import os; {code}; print(os.environ.get('MKL_CBWR'))"
        out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
        return out.stdout.strip().splitlines()[-1]

    probe = "from marops_cli.workers.threads import portable_blas; portable_blas()"
    assert mkl_cbwr(probe) == "COMPATIBLE"
    assert mkl_cbwr("import marops_cli") == "COMPATIBLE"
    assert mkl_cbwr("import torch; import marops_cli") == "None"
    assert mkl_cbwr("import torch; " + probe) == "None"
    monkeypatch.setenv("MKL_CBWR", "AVX2")
    assert mkl_cbwr(probe) == "AVX2"
    assert mkl_cbwr("import marops_cli") == "AVX2"
    monkeypatch.delenv("MKL_CBWR")
    probe = (
        "import os, sys; from marops_cli.cli import app; sys.argv = ['marops', '-V'];"
        "import atexit; atexit.register(lambda: print(os.environ.get('MKL_CBWR')));"
        "app.main()"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert out.stdout.strip().splitlines()[-1] == "COMPATIBLE", out


def test_a_pool_starts_at_most_4_processes_per_cpu(monkeypatch: pytest.MonkeyPatch) -> None:
    """--workers 6 on one CPU starts 4 processes, with the same results; a run says so
    in one warning line, and says nothing when its jobs are fewer or its cluster remote."""
    from marops_cli.errors import spelled
    from marops_cli.workers import pool

    monkeypatch.setattr(pool, "usable_cpus", lambda: 1)
    assert pool.local_workers(6) == 4 and pool.local_workers(3) == 3
    jobs = [Square(i, x) for i, x in enumerate(range(8))]
    with LocalPool(SquareWork(), 6) as started:
        assert started._pool._processes == 4
        assert [square for square, _, _ in started.results(jobs)] == [x * x for x in range(8)]
    note = pool.workers_note(6)
    assert note is not None
    assert spelled(note) == (
        "--workers 6 is more than 4 per CPU this process may use (1): 4 worker processes "
        "run (the results are the same)"
    )
    assert pool.workers_note(6, "local") == note
    assert pool.workers_note(6, None, jobs=3) is None  # 3 jobs start 3 processes
    assert pool.workers_note(6, "tcp://10.0.0.1:8786") is None
    assert pool.workers_note(4) is None
