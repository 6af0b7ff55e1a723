"""Training data: the split by date, depots from the training days, prepared days.

A run trains on one or several files (cities), each segmented into one or several
area counts and flown with one or several fleet sizes: every combination is a
training scenario (docs/method.md §6, generalisation).
"""

from __future__ import annotations

import datetime as dt
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..config import PlannerConfig, battery_preset, check_battery_regimes, count, override
from ..data.dates import split_by_date
from ..data.frame import Frame
from ..data.prepare import prepare_day
from ..data.reader import read_lade
from ..data.table import DayRequests, LadeTable
from ..errors import InputError, naming
from ..io.meta import file_sha256
from ..sim.scenario import load_scenario
from .config import TrainConfig
from .rollout import TrainScenario, WorkerContext

MAX_SCENARIOS = 1_000
"""The most scenarios one training run makes (files × area counts × fleet sizes ×
battery settings, docs/config.md): each is evaluated on its held-out days against the
baselines, so 1000 is days of evaluation already, far more than an actor needs (the
shipped ones trained on 16 and 216). More are refused before any file is read."""


def split_days(days: list[dt.date], train: list[dt.date] | None = None) -> tuple[list, list]:
    """(training days, held-out days): the given ones and the rest, else the first
    80 % of the file's dates and the last 20 % (:func:`~marops_cli.data.dates.split_by_date`,
    docs/method.md §6)."""
    days = sorted(days)
    if train is not None:
        missing = [d.isoformat() for d in train if d not in set(days)]
        if missing:
            raise InputError(f"training days not in the file: {', '.join(missing[:5])}")
        return sorted(train), [d for d in days if d not in set(train)]
    return split_by_date(days)


def _prepared(
    table: LadeTable, frame: Frame, dates: list[dt.date], cfg: PlannerConfig, named: bool
) -> tuple[list[dt.date], list[DayRequests]]:
    """The days of ``dates`` that have requests in ``frame``, prepared; a day with none
    (all outside the study area or service hours) teaches nothing and is left out,
    unless ``named`` (asked for by ``--dates``: an error naming it, as evaluate's)."""
    pairs = []
    for d in dates:  # every date is the file's: prepare_day raises only for an empty day
        try:
            pairs.append((d, prepare_day(table, frame, d, cfg.data)))
        except InputError:
            if named:
                raise
            continue
    return [d for d, _ in pairs], [r for _, r in pairs]


@dataclass
class TrainData:
    """The scenarios a run trains on: depots from the training days, prepared days."""

    ctx: WorkerContext
    files: list[dict[str, Any]]  # per file: file (name), sha256, train_days, heldout_days

    def start_event(self, episode: int, resumed: bool) -> dict[str, Any]:
        """A run's first progress event: where it starts, and on how many days, scenarios
        and files it trains."""
        return {
            "kind": "start",
            "episode": episode,
            "episodes": self.ctx.tcfg.episodes,
            "resumed": resumed,
            "train_days": sum(len(f["train_days"]) for f in self.files),
            "eval_days": sum(len(f["heldout_days"]) for f in self.files),
            "scenarios": len(self.ctx.scenarios),
            "files": len(self.files),
        }


def _check_scenarios(files: int, areas: int, fleets: int, batteries: int) -> None:
    """Refuse more than :data:`MAX_SCENARIOS` scenarios, one line naming the counts."""
    n = files * areas * fleets * batteries
    if n > MAX_SCENARIOS:
        said = " × ".join(
            count(k, thing)
            for k, thing in (
                (files, "file"),
                (areas, "area count"),
                (fleets, "fleet size"),
                (batteries, "battery setting"),
            )
        )
        raise InputError(
            f"training would make {n} scenarios ({said}), more than the "
            f"{MAX_SCENARIOS:,} one run trains on (docs/config.md): give fewer values of "
            "--n-depots, --drones, --spares or --batteries"
        )


def load_training_data(
    data: str | Path | Sequence[str | Path],
    cfg: PlannerConfig,
    tcfg: TrainConfig,
    train: list[dt.date] | None = None,
    *,
    n_depots: Sequence[int] = (),
    drones: Sequence[int] = (),
    spares: Sequence[int] = (),
    batteries: Sequence[str] = (),
) -> TrainData:
    """Read every file of ``data``, split each by date, segment each on its training
    days (once per area count of ``n_depots``, default the config's), prepare every day,
    and make one scenario per (file, area count, fleet size of ``drones``, batteries per
    depot of ``spares`` or battery regime of ``batteries`` (names of
    :data:`~marops_cli.config.BATTERY_PRESETS`), default the config's)."""
    paths = [Path(data)] if isinstance(data, (str, Path)) else [Path(p) for p in data]
    if not paths:
        raise InputError("no training data given")
    depot_counts = list(n_depots) or [cfg.segment.n_depots]
    fleets = list(drones) or [cfg.sim.drones]
    settings = _battery_settings(spares, batteries)
    _check_scenarios(len(paths), len(depot_counts), len(fleets), len(settings))
    scenarios: list[TrainScenario] = []
    files: list[dict[str, Any]] = []
    for fi, path in enumerate(paths):
        table = read_lade(path, cfg.data)
        try:
            train_dates, eval_dates = split_days(table.days(), train if fi == 0 else None)
        except InputError as exc:  # the days the file lacks: named with the file
            raise naming(exc, path) from None

        for k, n in enumerate(depot_counts):
            c = override(cfg, segment__n_depots=n)
            scn = load_scenario(path, c, replay_days=eval_dates, table=table)
            if k == 0:  # the study area and the days do not depend on the area count
                named = fi == 0 and train is not None
                tr_dates, tr_reqs = _prepared(table, scn.frame, train_dates, cfg, named)
                ev_dates, ev_reqs = _prepared(table, scn.frame, eval_dates, cfg, False)
                if not tr_reqs:
                    raise InputError(
                        "no training day has requests in the study area within service hours",
                        file=str(path),
                    )
            for u in fleets:
                for b, ops in settings:
                    name = f"{path.name}:{n}x{u}" + ("" if b is None else f"/{b}")
                    cu = override(c, sim__drones=u, **ops)
                    scenarios.append(TrainScenario(name, scn.depots, cu, tr_reqs, ev_reqs))
        files.append(
            {
                "file": path.name,
                "sha256": file_sha256(path),
                "train_days": [d.isoformat() for d in tr_dates],
                "heldout_days": [d.isoformat() for d in ev_dates],
            }
        )
    return TrainData(WorkerContext(scenarios, tcfg), files)


def _battery_settings(
    spares: Sequence[int], batteries: Sequence[str]
) -> list[tuple[int | str | None, dict[str, Any]]]:
    """Each scenario's batteries: its name's suffix and its ``[ops]`` overrides, one per
    count of ``spares`` or regime of ``batteries``, or the config's (None, none)."""
    check_battery_regimes(batteries, bool(spares))
    if batteries:
        return [(b, battery_preset(b)) for b in batteries]
    return [(b, {"ops__batteries_per_depot": b}) for b in spares] or [(None, {})]


def fingerprint(td: TrainData) -> dict[str, Any]:
    """What a checkpoint must share with the run that resumes it."""
    keep = td.ctx.tcfg.model_dump(exclude={"episodes", "workers", "eval_every", "checkpoint_every"})
    out: dict[str, Any] = {
        "data_sha256": td.files[0]["sha256"],
        "train_days": td.files[0]["train_days"],
        "planner": td.ctx.scenarios[0].cfg.model_dump(mode="json", exclude={"sim": {"policy"}}),
        "train": keep,
    }
    if len(td.files) > 1 or len(td.ctx.scenarios) > 1:
        out["files"] = [(f["sha256"], f["train_days"]) for f in td.files]
        out["scenarios"] = [(s.name, len(s.depots), s.cfg.sim.drones) for s in td.ctx.scenarios]
    return out


def other_run(ckpt: Path, stored: Any, now: dict[str, Any]) -> InputError | None:
    """The refusal of a checkpoint whose fingerprint ``stored`` is not this run's
    ``now``, naming the first setting that differs; None when they agree."""
    where = _difference(stored, now)
    if where is None:
        return None
    path, old, new = where
    what = "other data" if path in ("data_sha256", "files") else "other settings"
    return InputError(
        f"checkpoint was made with {what} ({path}: {_short(old)} in it, {_short(new)} now); "
        "pass --no-resume to start over",
        file=ckpt,
    )


def _difference(old: Any, new: Any, path: str = "") -> tuple[str, Any, Any] | None:
    """(dotted key, old value, new value) of the first difference, or None."""
    if isinstance(old, dict) and isinstance(new, dict):
        for k in [*new, *(k for k in old if k not in new)]:
            if k not in old or k not in new:
                return f"{path}{k}", old.get(k, "nothing"), new.get(k, "nothing")
            found = _difference(old[k], new[k], f"{path}{k}.")
            if found is not None:
                return found
        return None
    if isinstance(old, list | tuple) and isinstance(new, list | tuple) and len(old) == len(new):
        for a, b in zip(old, new, strict=True):
            if _difference(a, b, path) is not None:
                return path.rstrip("."), old, new
        return None
    return None if old == new else (path.rstrip(".") or "fingerprint", old, new)


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def other_algorithm(ckpt: Path, algorithm: str) -> InputError | None:
    """The refusal of a checkpoint of the other ``--algorithm`` (the recurrent actor's
    is a torch archive, the landing actor's JSON); None for one of ``algorithm``'s kind
    or any other file (its own loader says why)."""
    ppo = zipfile.is_zipfile(ckpt)
    if algorithm == "es" and ppo:
        kind = "the recurrent actor's training checkpoint (--algorithm ppo), not the landing's"
    elif algorithm != "es" and not ppo and ckpt.read_bytes()[:1] == b"{":
        kind = "the landing actor's training checkpoint (--algorithm es), not the recurrent's"
    else:
        return None
    return InputError(f"{kind}; pass --no-resume or another --out", file=ckpt)


MAX_CHECKPOINT_BYTES = 1 << 30
"""What a training checkpoint may unpack to: a recurrent actor's is well under a
megabyte (its networks, optimiser and learning curve)."""


def oversized_checkpoint(ckpt: Path) -> InputError | None:
    """The refusal of a torch archive that says it unpacks to more than
    :data:`MAX_CHECKPOINT_BYTES` (loading it would take that memory first); None for any
    other file."""
    try:
        with zipfile.ZipFile(ckpt) as archive:
            size = sum(info.file_size for info in archive.infolist())
    except (OSError, ValueError, zipfile.BadZipFile):
        return None  # the loader says why
    if size <= MAX_CHECKPOINT_BYTES:
        return None
    return InputError(
        f"not a training checkpoint: it unpacks to {size / 1e9:,.1f} GB, far more than a "
        "checkpoint holds; pass --no-resume or another --out",
        file=ckpt,
    )


def edited_checkpoint(ckpt: Path, kind: str, exc: Exception | str) -> InputError:
    """The refusal of a checkpoint ``ckpt`` with this run's fingerprint whose contents
    do not restore (``exc``, or what is wrong with them): an edited file, not this run's;
    ``kind`` says whose."""
    what = f"no key {exc}" if isinstance(exc, KeyError) else " ".join(str(exc).split())
    return InputError(f"not {kind} of this run ({what}); pass --no-resume", file=ckpt)
