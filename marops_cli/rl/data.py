"""Training data: the split by date, depots from the training days, prepared days."""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..config import PlannerConfig
from ..data.prepare import prepare_day
from ..data.reader import read_lade
from ..data.table import DayRequests
from ..errors import InputError
from ..io.meta import file_sha256
from ..sim.jobs import load_scenario
from .config import TrainConfig
from .rollout import WorkerContext


def split_days(days: list[dt.date], train: list[dt.date] | None = None) -> tuple[list, list]:
    """(training days, held-out days): the given ones and the rest, else the first
    80 % of the file's dates and the last 20 % (docs/method.md §6; at least one of each when
    the file has two days or more)."""
    days = sorted(days)
    if train is not None:
        missing = [d.isoformat() for d in train if d not in set(days)]
        if missing:
            raise InputError(f"training days not in the file: {', '.join(missing[:5])}")
        return sorted(train), [d for d in days if d not in set(train)]
    if len(days) < 2:
        return days, []
    n = min(len(days) - 1, max(1, round(0.8 * len(days))))
    return days[:n], days[n:]


@dataclass
class TrainData:
    """The scenario a run trains on: depots from the training days, prepared days."""

    ctx: WorkerContext
    train_dates: list[dt.date]
    eval_dates: list[dt.date]
    sha256: str
    name: str


def load_training_data(
    data: str | Path, cfg: PlannerConfig, tcfg: TrainConfig, train: list[dt.date] | None = None
) -> TrainData:
    """Read ``data``, split it by date, segment on the training days, prepare every day."""
    table = read_lade(data, cfg.data)
    train_dates, eval_dates = split_days(table.days(), train)
    scn = load_scenario(data, cfg, replay_days=eval_dates, table=table)

    def prep(dates: list[dt.date]) -> tuple[list[dt.date], list[DayRequests]]:
        pairs = [(d, prepare_day(table, scn.frame, d, cfg.data)) for d in dates]
        pairs = [(d, r) for d, r in pairs if len(r) > 0]  # a day with no request teaches nothing
        return [d for d, _ in pairs], [r for _, r in pairs]

    train_dates, train_reqs = prep(train_dates)
    eval_dates, eval_reqs = prep(eval_dates)
    if not train_reqs:
        raise InputError("no training day has requests in the study area", file=str(data))
    ctx = WorkerContext(scn.depots, cfg, tcfg, train_reqs, eval_reqs)
    return TrainData(ctx, train_dates, eval_dates, file_sha256(data), Path(data).name)


def fingerprint(td: TrainData) -> dict[str, Any]:
    """What a checkpoint must share with the run that resumes it."""
    keep = td.ctx.tcfg.model_dump(exclude={"episodes", "workers", "eval_every", "checkpoint_every"})
    return {
        "data_sha256": td.sha256,
        "train_days": [d.isoformat() for d in td.train_dates],
        "planner": td.ctx.cfg.model_dump(mode="json", exclude={"sim": {"policy"}}),
        "train": keep,
    }
