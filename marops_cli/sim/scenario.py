"""A study area ready to fly: the scenario (rows, study frame, depots), its fleet, the
policy a method flies, and one window or one day of it, with its metrics and route
tables. The use cases (``marops_cli/app/``) and evaluate's workers build on these.

A *method* (docs/method.md §7) is a segmentation, a flight-range policy and a planning scope.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import socket
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa

from ..config import MAX_DAY_STOPS, OpsConfig, PlannerConfig
from ..data.arrow import is_text, parquet_rows, read_parquet, read_parquet_schema
from ..data.frame import Frame
from ..data.jsonfile import first_line
from ..data.prepare import arrival_windows, check_days_in_file, prepare_day, study_frame
from ..data.reader import read_lade, sha256_file
from ..data.table import DayRequests, LadeTable
from ..energy import EnergyModel
from ..errors import InputError, naming, not_found, option
from ..methods import METHODS as _METHODS
from ..methods import method as method_spec
from ..plans.window import WindowPlan
from ..policies.base import Policy, start_day
from ..policies.landing import operating_model
from ..policies.registry import (
    SHIPPED,
    PolicySpec,
    actor_files,
    landing_actor_file,
    make_policy,
)
from ..segment.cache import cached_depots
from ..segment.depots import Depots
from ..segment.methods import segment_points
from ..segment.run import history_points
from .fleet import Fleet, as_fleet
from .fleet import load_fleet as _load_fleet
from .metrics import day_metrics
from .replay import FlownDay, fly_day
from .state import DayState
from .step import WindowStep, plan_step

# method -> (segmentation, policy), live over the registry (marops_cli/methods.py).
METHODS = _METHODS
# What a worker replaying days imports before its first job (its fork server preloads
# it); an actor's run adds torch and the actor loader.
REPLAY_MODULES = ("marops_cli.sim.days", "marops_cli.io.tables", "pyarrow.parquet")
ACTOR_MODULES = ("torch", "marops_cli.policies.torchscript")
# Messages for a method whose shipped actor this install lacks, by policy kind.
_NOT_SHIPPED = {
    "learned": "needs a trained actor: none is shipped at policies/{name}; pass --policy "
    "PATH.pt or a baseline (stay, random, greedy)",
    "direct": "needs a trained MAPPO actor: none is shipped at policies/{name}; pass "
    "--policy PATH.pt (made by marops train --method mappo)",
}


def loads_actor(method: str, policy: str | None = None, *, paper: bool = True) -> bool:
    """Whether ``method`` (with ``policy``, a ``--policy`` spec) flies a trained actor
    that needs torch, under the paper's operating model (``paper``) or the realistic
    one: the recurrent actors do, the landing actor (16 numbers NumPy reads: the
    realistic model's ``marops``) does not; an unknown method or policy says no (it
    fails later, naming itself)."""
    spec = policy or (method_spec(method).policy if method in METHODS else "")
    try:
        parsed = PolicySpec.parse(spec)
    except InputError:
        return False
    if not parsed.loads_actor:
        return False
    resolved = parsed.shipped(paper)  # None: not shipped with this install (fails later)
    return resolved is None or not landing_actor_file(str(resolved.path))


def replay_modules(actor: bool) -> tuple[str, ...]:
    """What a worker replaying days preloads: the planner and the route tables, and for
    an ``actor`` torch and the actor loader."""
    return (*REPLAY_MODULES, *(ACTOR_MODULES if actor else ()))


def other_actor(method: str, policy: Policy, sha256: str) -> str | None:
    """Why ``policy`` is not the trained actor (SHA-256 ``sha256``) the command resolved
    for ``method``, or None: a worker machine with another marops version or another
    actor file at that path would give other results under the same settings."""
    found = policy.identity
    if not isinstance(found, Path) or sha256_file(found) != sha256:
        return (
            f"a worker on {socket.gethostname()} runs another trained actor for {method} "
            f"({found}); install the same marops and actor files on every machine"
        )
    return None


def method_policy(
    method: str,
    policy: str | None,
    seed: int,
    *,
    actors: Mapping[str, Path] | None = None,
    trust: bool = False,
    ops: OpsConfig | None = None,
) -> Policy:
    """The policy a method runs: ``policy`` (a spec) when given, else the method's own,
    whose shipped actor ``actors`` replaces by policy kind (``learned``, ``direct``:
    evaluate's ``--policy`` and ``--mappo-policy``); ``trust``: ``cfg.sim.trust_actor``;
    ``ops``: the run's operating model, whose shipped actors it flies (None: the paper's)."""
    resolved, model = _resolve_policy(method, policy, actors, ops)
    return make_policy(resolved, seed, trust=trust, model=model)


def _resolve_policy(
    method: str,
    policy: str | None,
    actors: Mapping[str, Path] | None,
    ops: OpsConfig | None,
) -> tuple[PolicySpec, str]:
    """:func:`method_policy`'s spec, a shipped actor's as its file's, and the operating
    model's name."""
    if method not in METHODS:
        raise InputError(f"unknown method {method!r}: expected one of {', '.join(METHODS)}")
    spec = PolicySpec.parse(policy or method_spec(method).policy)
    if policy is None and actors and spec.kind in actors:
        spec = PolicySpec.actor(actors[spec.kind])
    model = "paper" if ops is None else operating_model(ops)
    resolved = spec.shipped(model == "paper")
    if resolved is None:
        why = _NOT_SHIPPED[spec.kind].format(name=SHIPPED[spec.kind])
        raise InputError(f"method {method!r} {why}")
    return resolved, model


def policy_files(
    method: str,
    policy: str | None,
    *,
    actors: Mapping[str, Path] | None = None,
    ops: OpsConfig | None = None,
) -> list[Path]:
    """The files the actor :func:`method_policy` flies is read from (the given path, its
    ``.pt``, ``.safetensors`` and sidecar ``.json``); none for a rule. They are inputs of
    the run: no output may replace one."""
    resolved, _ = _resolve_policy(method, policy, actors, ops)
    return [] if resolved.path is None else actor_files(resolved.path)


@dataclass
class Scenario:
    """A LaDe file with its study area and service areas, ready to replay days."""

    table: LadeTable
    frame: Frame
    depots: Depots
    cfg: PlannerConfig
    history_days: list[dt.date]
    hub: int = 0
    """The hub this study area is (docs/method.md §1.1); 0 for a single study area."""


def load_scenario(
    data: str | Path,
    cfg: PlannerConfig,
    *,
    depots_path: str | Path | Depots | None = None,
    replay_days: Sequence[dt.date] = (),
    table: LadeTable | None = None,
    hub: int = 0,
    cache: bool = True,
) -> Scenario:
    """Read the file and take depots from ``depots_path`` (a depots file, or depots in
    memory checked already, not changed: the scenario holds a copy) or segment the
    history days.

    History days are the file's days other than the replayed ones (all days when
    that leaves none), so the depots never see the demand they are judged on.
    ``cache=False`` segments without the depots cache (data held in memory: the
    Python API writes nothing it was not asked to).
    """
    table = table if table is not None else read_lade(data, cfg.data)
    check_days_in_file(table, replay_days)
    all_days = table.days()
    unseen = [d for d in all_days if d not in set(replay_days)]
    history = unseen or all_days
    if depots_path is not None:
        if isinstance(depots_path, Depots):
            depots, source = dataclasses.replace(depots_path), "depots"
        else:
            depots, source = Depots.load(depots_path, cfg.segment.n_actions), str(depots_path)
        _check_depots_area(table, depots, source)
        if depots.n_actions != cfg.segment.n_actions:
            depots = depots.with_actions(cfg.segment.n_actions)
        depots.arrivals = arrival_profile(table, depots, unseen, cfg) if unseen else None
        return Scenario(table, depots.frame, depots, cfg, history, hub)
    frame = study_frame(table, cfg.data, history)

    def make() -> Depots:
        pts, _ = history_points(table, frame, history)
        try:
            return segment_points(pts[:, 0], pts[:, 1], frame, cfg.segment)
        except InputError as exc:
            raise naming(exc, table.source.path) from None

    # k-means is the slowest step of a run without --depots: the depots are cached by
    # the hash of what they are made from (docs/outputs.md, "Depots cache").
    depots = cached_depots(table, history, frame, cfg.data, cfg.segment, make) if cache else make()
    # The profile never sees a replayed day: with no other day there is none (zeros).
    depots.arrivals = arrival_profile(table, depots, unseen, cfg) if unseen else None
    return Scenario(table, frame, depots, cfg, history, hub)


def _check_depots_area(table: LadeTable, depots: Depots, path: str | Path) -> None:
    """A depots file whose study area holds none of the file's requests was made for
    another area: the depots file is the culprit, not the data."""
    f = depots.frame
    if len(table) and not f.contains(*f.to_xy(table.lng, table.lat)).any():
        raise InputError(
            f"its study area ({f.size_km:g} km square around {f.center_lng:.5f}, "
            f"{f.center_lat:.5f}) holds none of the requests of {table.source.name}: "
            "depots of another area?",
            file=path,
            column="frame",
        )


def arrival_profile(
    table: LadeTable, depots: Depots, days: Sequence[dt.date], cfg: PlannerConfig
) -> np.ndarray:
    """``(N, W)``: requests becoming visible per service area and window on the mean
    history day (docs/method.md §6: what the actor anticipates demand from)."""
    x, y, w = arrival_windows(table, depots.frame, days, cfg.data)
    n, n_w = len(depots), cfg.data.n_windows
    counts = np.bincount(depots.assign(x, y) * n_w + w, minlength=n * n_w)
    return counts.reshape(n, n_w) / max(1, len(days))


def load_fleet(path: str | Path | None, depots: Depots, n_drones: int, cfg: PlannerConfig) -> Fleet:
    """The fleet file's drones and types (docs/outputs.md, "Fleet file"), else ``n_drones``
    drones of the default type (``cfg``'s ``[energy]``) over the busiest depots."""
    return _load_fleet(path, depots, n_drones, cfg.energy)


def delivered_file(path: str | Path) -> Path:
    """The stops file ``--delivered`` names: the file, or a folder's ``stops.parquet``."""
    p = Path(path)
    return p / "stops.parquet" if p.is_dir() else p


Delivered = Mapping[str, frozenset[tuple[float, float]] | None]
"""Order ids delivered, each with the places (lng, lat) of its stops; None where the file
gives no places (every request of the id counts as delivered)."""


def delivered_orders(path: str | Path) -> Delivered:
    """The orders already delivered according to an earlier stops Parquet file (or the
    ``stops.parquet`` of an output folder): each id with the places its stops reached, so
    that of several requests sharing an order id (docs/decisions.md, "Reading LaDe")
    only those delivered leave the window; by id alone for a file without ``lng`` and
    ``lat``."""
    p = delivered_file(path)
    if p.suffix.lower() == ".json" or (not p.exists() and (p.parent / "stops.json").is_file()):
        raise InputError(
            "--delivered reads the stops.parquet a run writes, and a run with --format "
            "json writes stops.json instead: replay that day with --format parquet",
            file=p,
        )
    if not p.exists():  # missing, a dangling link or a loop of links
        raise not_found(p, "delivered file")
    if not p.is_file():  # a pipe or a device: no stops file
        raise InputError("not a marops stops file (not a regular file)", file=p)
    try:
        names = set(read_parquet_schema(p).names)
        for name in ("kind", "order_id"):
            if name not in names:
                raise InputError(f"not a marops stops file (no column {name!r})", file=p)
        # Each row is read into memory (30 million repeated rows, 168 kB: 3 GB and a
        # minute and a half): a file of more than a day's stops is refused by its footer.
        rows = parquet_rows(p)
        if rows > MAX_DAY_STOPS:
            raise InputError(
                f"not a marops stops file ({rows:,} rows, more than the "
                f"{MAX_DAY_STOPS:,} stops of any day marops plans)",
                file=p,
            )
        placed = {"lng", "lat"} <= names
        table = read_parquet(p, columns=["kind", "order_id", *(["lng", "lat"] if placed else [])])
    except FileNotFoundError as exc:  # removed meanwhile
        raise not_found(p, "delivered file") from exc
    except (OSError, ValueError, KeyError) as exc:
        raise InputError(f"not a marops stops file ({first_line(exc)})", file=p) from exc
    for name in ("kind", "order_id"):  # text as marops writes them (a list matches nothing)
        t = table.schema.field(name).type
        t = t.value_type if pa.types.is_dictionary(t) else t
        whole = name == "order_id" and pa.types.is_integer(t)  # ids as numbers, by hand
        text = is_text(t) or pa.types.is_null(t)
        if not (whole or text):
            raise InputError(
                f"not a marops stops file (expected a column of text, got {t})",
                file=p,
                column=name,
            )
    return _delivered_places(table, p)


def _delivered_places(table: pa.Table, p: Path) -> Delivered:
    """:func:`delivered_orders` of a stops table whose ``kind`` and ``order_id`` were
    checked: its customers' ids, each with its stops' places where the table has them."""
    kind = table.column("kind").to_pylist()
    ids = table.column("order_id").to_pylist()
    placed = "lng" in table.column_names
    lng: list[float | None] = [None] * len(kind)
    lat: list[float | None] = [None] * len(kind)
    if placed:
        for name in ("lng", "lat"):
            t = table.schema.field(name).type
            if not (pa.types.is_floating(t) or pa.types.is_integer(t)):
                raise InputError(
                    f"not a marops stops file (expected a column of numbers, got {t})",
                    file=p,
                    column=name,
                )
        lng, lat = table.column("lng").to_pylist(), table.column("lat").to_pylist()
    places: dict[str, set[tuple[float, float]] | None] = {}
    for row, (k, i) in enumerate(zip(kind, ids, strict=True)):
        if k != "customer" or i is None:
            continue
        seen = places.setdefault(str(i), set() if placed else None)
        x, y = lng[row], lat[row]
        if x is None or y is None:
            places[str(i)] = None  # a stop of no place: every request of its id
        elif seen is not None:
            seen.add((float(x), float(y)))
    return {i: None if v is None else frozenset(v) for i, v in places.items()}


def delivered_mask(reqs: DayRequests, delivered: Delivered | set[str]) -> np.ndarray:
    """True for each request of ``reqs`` that ``delivered`` (:func:`delivered_orders`, or
    a set of order ids) says was delivered: its id with its place, or its id alone where
    no place is given."""
    ids = reqs.order_id.astype(str)
    done = np.isin(ids, np.array(sorted(delivered), dtype=str))
    if isinstance(delivered, Mapping):
        for i in np.flatnonzero(done):
            places = delivered[ids[i]]
            if places is not None:
                done[i] = (float(reqs.lng[i]), float(reqs.lat[i])) in places
    return done


def plan_one_window(
    scn: Scenario,
    day: dt.date,
    window: int,
    fleet: Fleet | np.ndarray,
    policy: Policy,
    delivered: Delivered | set[str] | None = None,
) -> tuple[WindowPlan, DayRequests]:
    """Plan window ``window`` of ``day`` with the ``fleet`` (or drones at these depots, of
    the default type) (docs/method.md §4)."""
    cfg = scn.cfg
    fl = as_fleet(fleet, cfg.energy)
    reqs = prepare_day(scn.table, scn.frame, day, cfg.data)
    if not 0 <= window < reqs.n_windows:
        raise InputError(f"{option('window')} {window} is outside 0..{reqs.n_windows - 1}")
    state = DayState(
        reqs, scn.depots, fl.depot, cfg.plan.coverage, cfg.plan.ties, drone_models=fl.models()
    )
    if delivered:
        state.delivered_w[delivered_mask(reqs, delivered)] = max(0, window - 1)
    start_day(policy, cfg, cfg.sim.seed)
    view = state.view(window)
    return plan_step(view, policy.act(view), WindowStep.of(policy, cfg)), reqs


def replay(
    scn: Scenario,
    day: dt.date,
    fleet: Fleet | np.ndarray,
    policy: Policy,
    method: str,
    on_window: Callable[[WindowPlan], None] | None = None,
) -> tuple[FlownDay, DayRequests, dict[str, object]]:
    """Replay ``day`` with the ``fleet`` (or drones at these depots, of the default type)
    and compute its metrics."""
    fl = as_fleet(fleet, scn.cfg.energy)
    reqs = prepare_day(scn.table, scn.frame, day, scn.cfg.data)
    how = WindowStep.of(policy, scn.cfg)
    res = fly_day(
        reqs,
        scn.depots,
        fl.depot,
        policy,
        scn.cfg,
        method=method,
        how=how,
        on_window=on_window,
        drone_models=fl.models(),
    )
    return res, reqs, day_metrics(res, how.model, fl, hub=scn.hub)


def route_tables(
    scn: Scenario, reqs: DayRequests, plans: Sequence[WindowPlan], fleet: Fleet, method: str
) -> tuple[pa.Table, pa.Table]:
    """The stops and routes tables (docs/outputs.md) of ``plans``, each drone with its
    type, in the scenario's hub."""
    from ..io.tables import build_tables

    return build_tables(
        reqs,
        scn.depots,
        plans,
        EnergyModel.of(scn.cfg.energy),
        method,
        scn.cfg.data.tz,
        drone_models=fleet.models(),
        drone_types=fleet.type_names(),
        hub=scn.hub,
    )
