"""Run an evaluation's jobs, in parallel over worker processes, in a fixed result order.

Every job builds its own config, fleet and policy from the job alone (the policy is
reset with the job's seed at the start of the day), so a job's metrics do not
depend on which worker runs it or on what that worker ran before. Results are put
back in job order, so ``--workers 1`` and ``--workers 2`` give the same rows
(except the wall-time columns).
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import multiprocessing as mp
import os
import signal
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..config import PlannerConfig, override
from ..data.dates import format_days
from ..data.reader import read_lade, sha256_file
from ..data.table import LadeTable
from ..errors import InputError, MaropsError, RunError
from ..methods import Method, register
from ..methods import method as method_spec
from ..policies.base import Policy
from ..sim.jobs import METHODS, Scenario, load_fleet, load_scenario, replay
from ..sim.jobs import method_policy as _method_policy
from .settings import Job, Setting, check_settings, plan_jobs, split_days

OnResult = Callable[[int, int, Job], None]


@dataclass
class Prepared:
    """Everything a run needs: the data read once, depots per segmentation, the jobs."""

    source: LadeTable  # the whole file (its report and identity)
    cfg: PlannerConfig
    methods: list[str]
    days: list[dt.date]
    settings: list[Setting]
    repeats: int
    jobs: list[Job]
    scenarios: dict[tuple[str, int], Scenario]  # (segmentation, depots) -> test-day scenario
    actors: dict[str, Path]  # policy kind -> trained actor given on the command line
    actor_files: dict[str, Path]  # method -> the trained actor it runs
    specs: dict[str, Method] = field(default_factory=dict)
    """The methods' registry entries, so spawned workers know methods registered at run
    time (marops_cli/methods.py)."""


# Policy kinds of METHODS that load a trained actor -> the evaluate flag that overrides it.
ACTOR_FLAGS = {"learned": "--policy", "direct": "--mappo-policy"}


def method_policy(method: str, actors: dict[str, Path], seed: int) -> Policy:
    """The method's policy; ``actors`` overrides the shipped actor per policy kind."""
    kind = METHODS[method][1]
    spec = f"torchscript:{actors[kind]}" if kind in actors else None
    return _method_policy(method, spec, seed)


def check_methods(methods: Sequence[str], actors: dict[str, Path] | None = None) -> dict[str, Path]:
    """Load every method's policy once; fail with one line naming what is missing.

    Returns the trained actor file of each method that runs one.
    """
    if not methods:
        raise InputError("--methods lists no method")
    for m in methods:
        if m not in METHODS:
            raise InputError(f"unknown method {m!r}: this build has {', '.join(METHODS)}")
    for kind, path in (actors or {}).items():
        if any(METHODS[m][1] == kind for m in methods) and not Path(path).is_file():
            raise InputError(f"trained actor not found ({ACTOR_FLAGS[kind]})", file=path)
    files: dict[str, Path] = {}
    for m in methods:
        try:
            pol = method_policy(m, actors or {}, 0)
        except InputError as exc:
            flag = ACTOR_FLAGS.get(METHODS[m][1])
            if flag is None:
                raise
            raise InputError(
                f"{exc}; for evaluate: {flag} PATH.pt, or leave {m} out of --methods"
            ) from None
        if isinstance(pol.identity, Path):  # a trained actor file
            files[m] = pol.identity
    return files


def prepare(
    data: str | Path,
    cfg: PlannerConfig,
    methods: Sequence[str],
    settings: Sequence[Setting],
    *,
    days: Sequence[dt.date] | None = None,
    split: str = "test",
    repeats: int = 1,
    actors: dict[str, Path] | None = None,
) -> Prepared:
    """Read ``data`` once, choose the days, segment the other days once per segmentation.

    ``days`` replays those dates; otherwise ``split`` picks the held-out (last 20 %)
    or training dates. Depots come from every day not replayed (``load_scenario``).
    """
    methods = list(dict.fromkeys(methods))
    actors = {k: Path(v) for k, v in (actors or {}).items()}
    actor_files = check_methods(methods, actors)  # fails here, not in a worker
    check_settings(cfg, settings, methods)
    if repeats < 1:
        raise InputError(f"--repeats expects at least 1, got {repeats}")
    table = read_lade(data, cfg.data)
    chosen = list(days) if days else split_days(table.days(), split)
    if not chosen:
        raise InputError(f"no days to evaluate (the file has {format_days(table.days())})")
    on_days = np.isin(table.delivery_day, np.array(chosen, dtype="datetime64[D]"))
    test_table = table.subset(on_days)  # workers need only the replayed days' rows
    scenarios: dict[tuple[str, int], Scenario] = {}
    for key in sorted({(METHODS[m][0], s.depots_n) for m in methods for s in settings}):
        seg_cfg = override(cfg, segment__method=key[0], segment__n_depots=key[1])
        scn = load_scenario(data, seg_cfg, replay_days=chosen, table=table)
        scenarios[key] = Scenario(test_table, scn.frame, scn.depots, seg_cfg, scn.history_days)
    jobs = plan_jobs(len(settings), methods, chosen, repeats, cfg.sim.seed)
    specs = {m: method_spec(m) for m in methods}
    return Prepared(
        table,
        cfg,
        methods,
        chosen,
        list(settings),
        repeats,
        jobs,
        scenarios,
        actors,
        actor_files,
        specs,
    )


# Per-process state of a worker (set once by the pool initializer).
_CTX: dict[str, Any] = {}


def _die_with_parent() -> None:
    """A worker whose parent is killed (kill -9) is killed too, not left running (Linux)."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes

    try:
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    if os.getppid() == 1:  # the parent died before the call
        os._exit(1)


def _init(prep: Prepared) -> None:
    # Ctrl-C reaches the whole process group: the parent stops the pool and keeps what
    # finished; workers ignore it, so no worker prints a traceback.
    if mp.current_process().name != "MainProcess":
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        _die_with_parent()
        # One thread per worker: the workers already fill the cores, and OpenMP/BLAS
        # threads on top only oversubscribe them.
        from threadpoolctl import threadpool_limits

        threadpool_limits(limits=1)  # the libraries loaded so far (numpy's BLAS)
        os.environ["OMP_NUM_THREADS"] = "1"  # and those loaded later (torch reads it)
        if "torch" in sys.modules:
            sys.modules["torch"].set_num_threads(1)
    for spec in prep.specs.values():  # methods registered in the parent at run time
        register(spec)
    _CTX.clear()
    _CTX["prep"] = prep
    _CTX["policies"] = {}


def run_job(job: Job) -> dict[str, Any]:
    """Replay one job's day; the metrics record of ``day_metrics``."""
    prep: Prepared = _CTX["prep"]
    setting = prep.settings[job.setting]
    cfg = setting.config(prep.cfg, job.method, job.seed)
    base = prep.scenarios[(METHODS[job.method][0], setting.depots_n)]
    scn = Scenario(base.table, base.frame, base.depots, cfg, base.history_days)
    key = (job.method, job.seed)
    if key not in _CTX["policies"]:
        _CTX["policies"][key] = method_policy(job.method, prep.actors, job.seed)
    fleet = load_fleet(None, base.depots, setting.drones, cfg)
    _, _, metrics = replay(scn, job.day, fleet, _CTX["policies"][key], job.method)
    return metrics


def _run_safe(job: Job) -> tuple[int, dict[str, Any] | None, str | None, int]:
    # Library errors cross the process boundary as text, then are raised again as one line.
    try:
        return job.index, run_job(job), None, 0
    except MaropsError as exc:
        return job.index, None, str(exc), exc.exit_code


def run_identity(prep: Prepared) -> str:
    """A digest of everything that decides an evaluation's rows: input, config, methods,
    settings, days, repeats and actors. A journal is resumed only under the same one."""
    doc = {
        "input": prep.source.source.to_dict(),
        "config": prep.cfg.model_dump(mode="json"),
        "methods": prep.methods,
        "settings": [s.columns() for s in prep.settings],
        "days": [d.isoformat() for d in prep.days],
        "repeats": prep.repeats,
        "actors": {m: sha256_file(p) for m, p in sorted(prep.actor_files.items())},
    }
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=str).encode()).hexdigest()


def _job_key(job: Job) -> list[Any]:
    return [job.index, job.setting, job.method, job.repeat, job.seed, job.day.isoformat()]


class Journal:
    """Finished jobs, one JSON line each, so an interrupted evaluation resumes.

    The first line records the run identity; a journal made by another run is an
    error (the caller names it), never silently mixed in.
    """

    def __init__(self, path: Path, identity: str) -> None:
        self.path = path
        self.identity = identity
        self.done: dict[int, dict[str, Any]] = {}

    def open(self, jobs: Sequence[Job]) -> None:
        """Load the jobs an earlier run of the same evaluation finished, then append."""
        if self.path.is_file():
            lines = self.path.read_text(encoding="utf-8").splitlines()
            try:
                head = json.loads(lines[0]) if lines else {}
            except ValueError:
                head = {}
            if head.get("identity") != self.identity:
                raise InputError(
                    "holds an unfinished evaluation with other settings; delete it or "
                    "choose another --out",
                    file=self.path,
                )
            for line in lines[1:]:
                try:
                    rec = json.loads(line)
                except ValueError:  # a line cut short by the interruption
                    continue
                i = int(rec["key"][0])
                if 0 <= i < len(jobs) and rec["key"] == _job_key(jobs[i]):
                    self.done[i] = rec["metrics"]
        else:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self.path.write_text(json.dumps({"identity": self.identity}) + "\n", "utf-8")

    def add(self, job: Job, metrics: dict[str, Any]) -> None:
        line = json.dumps({"key": _job_key(job), "metrics": metrics}, default=str)
        with open(self.path, "a", encoding="utf-8") as fh:
            fh.write(line + "\n")
            fh.flush()
            os.fsync(fh.fileno())

    def remove(self) -> None:
        self.path.unlink(missing_ok=True)


def run(
    prep: Prepared,
    workers: int = 2,
    on_result: OnResult | None = None,
    journal: Journal | None = None,
) -> list[dict[str, Any]]:
    """Metrics of every job, in job order, computed by ``workers`` processes; with a
    ``journal``, jobs it holds are not run again and each finished job is added."""
    if workers < 1:
        raise InputError(f"--workers expects at least 1, got {workers}")
    total = len(prep.jobs)
    results: list[dict[str, Any] | None] = [None] * total
    if journal is not None:
        journal.open(prep.jobs)
        for i, metrics in journal.done.items():
            results[i] = metrics
    todo = [job for job in prep.jobs if results[job.index] is None]
    done0 = total - len(todo)
    workers = max(1, min(workers, len(todo)))
    if not todo:
        outcomes: Any = iter(())
        pool = None
    elif workers == 1:
        _init(prep)
        outcomes = map(_run_safe, todo)
        pool = None
    else:
        # spawn: a fresh interpreter per worker, so no solver or Arrow thread state is
        # inherited half-initialised from the parent (fork is unsafe with threads).
        # Workers get only the replayed days' rows, not the whole file.
        slim = replace(prep, source=next(iter(prep.scenarios.values())).table)
        pool = mp.get_context("spawn").Pool(workers, initializer=_init, initargs=(slim,))
        outcomes = pool.imap_unordered(_run_safe, todo, chunksize=1)
    try:
        for done, (index, metrics, error, code) in enumerate(outcomes, start=done0 + 1):
            if error is not None:
                raise (InputError(error) if code == 2 else RunError(error))
            results[index] = metrics
            if journal is not None and metrics is not None:
                journal.add(prep.jobs[index], metrics)
            if on_result is not None:
                on_result(done, total, prep.jobs[index])
    finally:
        if pool is not None:
            pool.terminate()
            pool.join()
    return [r for r in results if r is not None]
