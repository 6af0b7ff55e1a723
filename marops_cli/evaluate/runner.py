"""Run an evaluation's jobs, in parallel over worker processes or on a Dask cluster
(marops_cli/workers), in a fixed result order.

Every job builds its own config, fleet and policy from the job alone (the policy is
reset with the job's seed at the start of the day), so a job's metrics do not
depend on which worker runs it or on what that worker ran before. Results are put
back in job order, so ``--workers 1``, ``--workers 2`` and a cluster give the same
rows (except the wall-time columns).
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from ..config import OpsConfig, PlannerConfig, override
from ..data.dates import format_days
from ..data.prepare import check_days_in_file, late_note, prepare_day
from ..data.reader import read_lade, sha256_file
from ..data.table import LadeTable
from ..errors import InputError, in_hub, not_a_file, option
from ..methods import Method, register
from ..methods import method as method_spec
from ..segment.hubs import (
    Hub,
    hub_areas,
    hub_demand,
    hub_owner,
    hubs_history,
    place_hubs,
    with_fleets,
)
from ..sim.scenario import (
    METHODS,
    Scenario,
    load_fleet,
    load_scenario,
    method_policy,
    other_actor,
    replay,
    replay_modules,
)
from ..workers import outcomes
from ..workers.pool import check_workers
from .settings import (
    Job,
    Setting,
    check_repeats,
    check_replays,
    check_settings,
    plan_jobs,
    replay_counts,
    split_days,
)

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
    scenarios: dict[tuple[int, str, int], Scenario]
    """(hub, segmentation, depots) -> the hub's test-day scenario (hub 0: the one area)."""
    actors: dict[str, Path]  # policy kind -> trained actor given on the command line
    actor_files: dict[str, Path]  # method -> the trained actor it runs
    specs: dict[str, Method] = field(default_factory=dict)
    """The methods' registry entries, so spawned workers know methods registered at run
    time (marops_cli/methods.py)."""
    hubs: list[Hub] = field(default_factory=list)
    """The hubs of a city run (``--hubs``, ``[data] area = "hubs"``); empty: one study
    area."""
    skipped: list[dt.date] = field(default_factory=list)
    """Days of the split left out: nothing to plan in the study area in service hours."""
    demand: list[int] = field(default_factory=list)
    """Each hub's orders on the history days, by which the hubs share a fleet."""
    history: list[dt.date] = field(default_factory=list)
    """The days hubs are placed over and share the fleet by (a city run)."""
    unplaced: int = 0
    """Squares the whole-export run left out: too few locations for their depots."""

    def drones(self, job: Job) -> int:
        """The fleet size of ``job``: its setting's, or over hubs its hub's own, else its
        share of the city's fleet (docs/method.md §1.1)."""
        if not self.hubs:
            return self.settings[job.setting].drones
        drones = self.settings[job.setting].drones
        fleets = with_fleets(self.hubs, self.demand, drones, self.cfg.sim.city_drones)
        return int(fleets[job.hub].drones or drones)


# Policy kinds of METHODS that load a trained actor -> the evaluate option that overrides it.
ACTOR_FLAGS = {"learned": option("policy"), "direct": option("mappo_policy")}


def check_methods(
    methods: Sequence[str],
    actors: dict[str, Path] | None = None,
    *,
    trust: bool = False,
    ops: OpsConfig | None = None,
) -> dict[str, Path]:
    """Load every method's policy once (``trust``: ``cfg.sim.trust_actor``; ``ops``: the
    operating model, whose shipped actors run); fail with one line naming what is missing.

    Returns the trained actor file of each method that runs one.
    """
    if not methods:
        raise InputError(f"{option('methods')} lists no method")
    for m in methods:
        if m not in METHODS:
            raise InputError(f"unknown method {m!r}: this build has {', '.join(METHODS)}")
    for kind, path in (actors or {}).items():
        if any(method_spec(m).policy == kind for m in methods) and not Path(path).is_file():
            missing = not_a_file(path, "trained actor")  # not found, or a folder
            raise InputError(f"{missing.message} ({ACTOR_FLAGS[kind]})", file=path)
    files: dict[str, Path] = {}
    for m in methods:
        try:
            pol = method_policy(m, None, 0, actors=actors, trust=trust, ops=ops)
        except InputError as exc:
            flag = ACTOR_FLAGS.get(method_spec(m).policy)
            if flag is None:
                raise
            raise InputError(
                f"{exc}; for evaluate: {flag} PATH.pt, or leave {m} out of {option('methods')}"
            ) from None
        if isinstance(pol.identity, Path):  # a trained actor file
            files[m] = pol.identity
    return files


def prepare(
    data: str | Path | LadeTable,
    cfg: PlannerConfig,
    methods: Sequence[str],
    settings: Sequence[Setting],
    *,
    days: Sequence[dt.date] | None = None,
    split: str = "test",
    repeats: int = 1,
    actors: dict[str, Path] | None = None,
    hubs: Sequence[Hub] | None = None,
    cache: bool = True,
) -> Prepared:
    """Read ``data`` once (or take the table read already), choose the days, segment the
    other days once per segmentation (``cache``: through the depots cache, as for a
    file; False for data held in memory, which leaves no file).

    ``days`` replays those dates; otherwise ``split`` picks the held-out (last 20 %)
    or training dates. Depots come from every day not replayed (``load_scenario``).
    With ``hubs`` (a city, docs/method.md §1.1) every hub is a study area with its own
    depots and fleet, an order belongs to the first hub whose square holds it, and a
    hub is replayed on the days it has requests.
    """
    methods = list(dict.fromkeys(methods))
    actors = {k: Path(v) for k, v in (actors or {}).items()}
    # Fails here, not in a worker.
    actor_files = check_methods(methods, actors, trust=cfg.sim.trust_actor, ops=cfg.ops)
    check_repeats(repeats)
    counts = replay_counts(len(settings), methods, repeats)
    check_replays(counts)  # before every setting's config is checked
    check_settings(cfg, settings, methods)
    table = data if isinstance(data, LadeTable) else read_lade(data, cfg.data)
    chosen = list(days) if days else split_days(table.days(), split)
    if not chosen:
        raise InputError(f"no days to evaluate (the file has {format_days(table.days())})")
    check_replays([*counts, (len(chosen), "day", "days")])  # before any segmentation
    if days:  # a day named that the file lacks, named as replay-day names it, before any work
        check_days_in_file(table, chosen)
    history = hubs_history(table, chosen)
    unplaced = 0
    if hubs is None and cfg.data.area == "hubs" and cfg.data.center is None:
        hubs, unplaced = place_hubs(table, cfg, history, max(s.depots_n for s in settings))
    owner = hub_owner(table, hubs) if hubs else None  # once: the hubs are set from here on
    demand = hub_demand(table, hubs, history, owner) if hubs else []
    path = Path(table.source.path)
    scenarios: dict[tuple[int, str, int], Scenario] = {}
    hub_days: list[tuple[int, list[dt.date]]] = []
    skipped: list[dt.date] = []
    areas = (
        [(0, cfg, table, chosen)]
        if not hubs
        else [
            (a.hub.id, a.cfg, a.table, a.days) for a in hub_areas(table, cfg, hubs, chosen, owner)
        ]
    )
    for hub, cfg_h, table_h, days_h in areas:
        if not days_h:
            continue  # a hub without requests on any of the days
        # Over hubs a hub holds its own orders alone, and may have none on a chosen day.
        replayable = [d for d in chosen if d in set(table_h.days())] if hubs else chosen
        on_days = np.isin(table_h.delivery_day, np.array(chosen, dtype="datetime64[D]"))
        test_table = table_h.subset(on_days)  # workers need only the replayed days' rows
        for key in sorted(
            {(method_spec(m).segmentation, s.depots_n) for m in methods for s in settings}
        ):
            seg_cfg = override(cfg_h, segment__method=key[0], segment__n_depots=key[1])
            try:
                scn = load_scenario(
                    path, seg_cfg, replay_days=replayable, table=table_h, hub=hub, cache=cache
                )
            except InputError as exc:  # a hub too sparse for its depots: which one
                raise in_hub(exc, hub) if hubs else exc from None
            scenarios[(hub, *key)] = Scenario(
                test_table, scn.frame, scn.depots, seg_cfg, scn.history_days, hub
            )
        if not hubs:  # every day has requests to plan, before any replay runs (as replay-day)
            frame = next(iter(scenarios.values())).frame
            for day in days_h:
                try:
                    prepare_day(table_h, frame, day, cfg_h.data)
                except InputError:
                    if days or len(skipped) + 1 == len(days_h):  # a day asked for, or none left
                        raise
                    skipped.append(day)  # a split's day with nothing to plan: left out
            days_h = chosen = [d for d in days_h if d not in skipped]
        hub_days.append((hub, days_h))
    if hubs:  # a day no hub plans anything on: refused when named, else left out
        planned = {d for _, ds in hub_days for d in ds}
        empty = [d for d in chosen if d not in planned]
        if empty and days:
            held = owner >= 0 if owner is not None else np.zeros(table.lng.size, dtype=bool)
            raise InputError(
                f"no requests on {empty[0].isoformat()} inside any hub's square due within "
                "service hours" + late_note(table, empty[0], held, cfg.data),
                file=path,
            )
        skipped += empty
        chosen = [d for d in chosen if d in planned]
    jobs = plan_jobs(len(settings), methods, chosen, repeats, cfg.sim.seed, hub_days=hub_days)
    if not jobs:
        raise InputError("no hub has requests on the days to evaluate", file=path)
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
        list(hubs or ()),
        skipped,
        demand,
        history,
        unplaced,
    )


def worker_modules(actor: bool) -> tuple[str, ...]:
    """What an evaluation's worker preloads (with torch for an ``actor``)."""
    return (__name__, *replay_modules(actor))


# Per-process state of a worker (set once by EvaluateWork.setup).
_CTX: dict[str, Any] = {}


def load(prep: Prepared) -> None:
    """Make ``prep`` this process's context for :func:`run_job`: the methods registered
    in the parent at run time, and no policy built yet."""
    for spec in prep.specs.values():
        register(spec)
    _CTX.clear()
    _CTX["prep"] = prep
    _CTX["policies"] = {}


def worker_context(prep: Prepared) -> Prepared:
    """What a worker receives: ``prep`` with only the replayed days' rows, not the file."""
    return replace(prep, source=next(iter(prep.scenarios.values())).table)


def run_job(job: Job) -> dict[str, Any]:
    """Replay one job's day; the metrics record of ``day_metrics``."""
    prep: Prepared = _CTX["prep"]
    setting = prep.settings[job.setting]
    base = prep.scenarios[(job.hub, method_spec(job.method).segmentation, setting.depots_n)]
    # The area's config (its square, with --hubs) with the setting, method and seed.
    cfg = setting.config(base.cfg, job.method, job.seed)
    scn = Scenario(base.table, base.frame, base.depots, cfg, base.history_days, job.hub)
    key = (job.method, job.seed)
    if key not in _CTX["policies"]:
        _CTX["policies"][key] = method_policy(
            job.method,
            None,
            job.seed,
            actors=prep.actors,
            trust=cfg.sim.trust_actor,
            ops=cfg.ops,
        )
    fleet = load_fleet(None, base.depots, prep.drones(job), cfg)
    _, _, metrics = replay(scn, job.day, fleet, _CTX["policies"][key], job.method)
    return metrics


@dataclass
class EvaluateWork:
    """An evaluation's jobs as a :class:`~marops_cli.workers.Work`: ``prep`` (the replayed
    days' rows only) and the SHA-256 of each trained actor ``evaluate`` resolved."""

    prep: Prepared
    actors: dict[str, str]

    @classmethod
    def of(cls, prep: Prepared) -> EvaluateWork:
        return cls(worker_context(prep), {m: sha256_file(p) for m, p in prep.actor_files.items()})

    @property
    def preload(self) -> tuple[str, ...]:
        return worker_modules(actor=bool(self.actors))

    def setup(self) -> None:
        load(self.prep)
        # The route pool's compiled kernels before the first job, so that no job's
        # running time carries their loading (plans are the same with or without them).
        from ..plans.kernels import kernels_now

        kernels_now()

    def run(self, job: Job) -> dict[str, Any]:
        return run_job(job)

    def refuse(self) -> str | None:
        """Why this worker would not run the trained actors ``evaluate`` resolved: a
        machine with another marops version or another actor file at that path would give
        other rows under the same run identity."""
        for method, sha in self.actors.items():
            trust = self.prep.cfg.sim.trust_actor
            policy = method_policy(
                method, None, 0, actors=self.prep.actors, trust=trust, ops=self.prep.cfg.ops
            )
            problem = other_actor(method, policy, sha)
            if problem is not None:
                return problem
        return None


def run_identity(prep: Prepared) -> str:
    """A digest of everything that decides an evaluation's rows: input, config, methods,
    settings, days, repeats and actors (:func:`identity_doc`). A jobs dataset is resumed
    only under the same one (docs/outputs.md "Evaluation")."""
    doc = identity_doc(prep)
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=str).encode()).hexdigest()


def identity_doc(prep: Prepared) -> dict[str, Any]:
    """What :func:`run_identity` digests, as JSON values: kept in the jobs dataset so that
    a run refused there can name what differs (:func:`identity_changes`)."""
    doc: dict[str, Any] = {
        "input": prep.source.source.to_dict(),
        "config": prep.cfg.model_dump(mode="json"),
        "methods": prep.methods,
        "settings": [s.columns() for s in prep.settings],
        "days": [d.isoformat() for d in prep.days],
        "repeats": prep.repeats,
        "actors": {m: sha256_file(p) for m, p in sorted(prep.actor_files.items())},
    }
    if prep.hubs:
        doc["hubs"] = [
            [h.id, h.frame.center_lng, h.frame.center_lat, h.frame.size_km, h.drones]
            for h in prep.hubs
        ]
    return dict(json.loads(json.dumps(doc, sort_keys=True, default=str)))


_IDENTITY_NAMES = {
    "input": "the input file",
    "config": "config",
    "methods": option("methods"),
    "days": "days",
    "repeats": option("repeats"),
    "actors": "trained actors",
    "hubs": option("hubs"),
}


def identity_changes(held: dict[str, Any], now: dict[str, Any], most: int = 4) -> list[str]:
    """What differs between the identity document ``held`` (of the jobs found) and
    ``now`` (this run's), each as ``WHAT: THERE there, HERE here`` (``--alpha: 0.5
    there, 0.3 here``, ``config sim.seed: 0 there, 3 here``); at most ``most`` named,
    then how many more."""
    changes: list[str] = []
    for key in ("input", "methods", "settings", "days", "repeats", "config", "actors", "hubs"):
        a, b = held.get(key), now.get(key)
        if a == b:
            continue
        if key == "settings" and isinstance(a, list) and isinstance(b, list):
            changes += _setting_changes(a, b) or ["the sweep's settings"]
        elif key == "config" and isinstance(a, dict) and isinstance(b, dict):
            changes += [
                f"config {path}: {_short(x)} there, {_short(y)} here"
                for path, x, y in _leaf_changes(a, b)
            ]
        elif key == "input" and isinstance(a, dict) and isinstance(b, dict):
            changes.append(f"the input file: {_input(a)} there, {_input(b)} here")
        elif key in ("methods", "days", "repeats"):
            changes.append(f"{_IDENTITY_NAMES[key]}: {_short(a)} there, {_short(b)} here")
        else:
            changes.append(_IDENTITY_NAMES.get(key, key))
    if len(changes) > most:
        changes = [*changes[:most], f"{len(changes) - most} more"]
    return changes


def _setting_changes(held: list[Any], now: list[Any]) -> list[str]:
    """Each sweep flag whose values differ: ``--alpha: 0.5 there, 0.3, 0.7 here``."""
    out = []
    for key, name in (
        ("alpha", "alpha"),
        ("drones", "drones"),
        ("coverage", "coverage"),
        ("depots_n", "n_depots"),
    ):
        a = list(dict.fromkeys(s.get(key) for s in held if isinstance(s, dict)))
        b = list(dict.fromkeys(s.get(key) for s in now if isinstance(s, dict)))
        if a != b:
            out.append(f"{option(name)}: {_short(a)} there, {_short(b)} here")
    return out


def _leaf_changes(a: Any, b: Any, path: str = "") -> list[tuple[str, Any, Any]]:
    """The dotted keys whose values differ between two JSON documents."""
    if isinstance(a, dict) and isinstance(b, dict):
        found = []
        for k in sorted(set(a) | set(b), key=str):
            sub = f"{path}.{k}" if path else str(k)
            found += _leaf_changes(a.get(k), b.get(k), sub)
        return found
    return [] if a == b else [(path, a, b)]


def _input(doc: dict[str, Any]) -> str:
    sha = str(doc.get("sha256") or "")
    return f"{doc.get('name')} (SHA-256 {sha[:12]}…)" if sha else str(doc.get("name"))


def _short(value: Any, most: int = 6) -> str:
    """A value of the identity as a reader would write it: lists joined, long ones cut."""
    if isinstance(value, list):
        items = [_short(v) for v in value]
        if len(items) > most:
            items = [*items[: most - 2], "…", items[-1]]
        return ", ".join(items) if items else "none"
    if isinstance(value, float):
        return f"{value:g}"
    return "none" if value is None else str(value)


class JobSink(Protocol):
    """Where finished jobs go as they finish (the jobs dataset, marops_cli/evaluate/dataset.py)."""

    def finished(self) -> set[int]:
        """Indices of the jobs already held: they are not run again."""
        ...

    def add(self, job: Job, metrics: dict[str, Any]) -> None:
        """Keep one finished job's metrics."""
        ...


def run(
    prep: Prepared,
    workers: int = 2,
    on_result: OnResult | None = None,
    sink: JobSink | None = None,
    scheduler: str | None = None,
) -> dict[int, dict[str, Any]]:
    """Metrics of the jobs this call ran, by job index, computed by ``workers`` processes
    (or on the Dask cluster at ``scheduler``, ``local`` for one on this machine); with
    a ``sink``, the jobs it holds are not run again and each finished job goes to it at
    once."""
    check_workers(workers)
    total = len(prep.jobs)
    skip = sink.finished() if sink is not None else set()
    todo = [job for job in prep.jobs if job.index not in skip]
    results: dict[int, dict[str, Any]] = {}
    work = EvaluateWork.of(prep)
    with outcomes(work, todo, workers, scheduler, "evaluate") as done_jobs:
        for done, outcome in enumerate(done_jobs, start=len(skip) + 1):
            index, metrics = outcome.index, outcome.value()
            results[index] = metrics
            if sink is not None:
                sink.add(prep.jobs[index], metrics)
            if on_result is not None:
                on_result(done, total, prep.jobs[index])
    return results
