"""The Python API: the commands as functions, for notebooks and scripts.

Each function runs exactly what its command runs and writes the same files (into
``out``, or a temporary folder when ``out`` is None), then returns them read back:
tables as ``pyarrow.Table`` (``.to_pandas()`` with pandas installed, or
``polars.from_arrow``) and metrics as dictionaries. Options are the commands' flags
as keyword arguments (``drones=16``, ``alpha=0.2``, ``config="planner.toml"``); errors
are raised as :class:`marops_cli.errors.InputError` (bad input) or
:class:`marops_cli.errors.MaropsError`, never printed.

    from marops_cli import api as marops

    depots = marops.segment("lade.csv", out="out/depots.json", dates="0801..0810")
    day = marops.replay_day("lade.csv", "0811", out="out/0811", depots="out/depots.json")
    day.metrics["avg_delay_h"], day.routes.to_pandas()
"""

from __future__ import annotations

import contextlib
import json
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pyarrow loads with the first call, so `import marops_cli` stays light
    import pyarrow as pa

__all__ = [
    "DayResult",
    "EvaluationResult",
    "evaluate",
    "plan_window",
    "read_lade",
    "replay_day",
    "segment",
]


@dataclass(frozen=True)
class DayResult:
    """A planned window or a replayed day: its stops and routes tables and metrics."""

    stops: pa.Table
    routes: pa.Table
    metrics: dict[str, Any]
    """The day's ``metrics.json`` record (``replay_day``), or the window's solver and
    objective (``plan_window``)."""
    folder: Path | None
    """Where the files are (None when they were written to a temporary folder)."""


@dataclass(frozen=True)
class EvaluationResult:
    results: pa.Table
    """One row per setting × method × day × repeat (docs/outputs.md, "Evaluation")."""
    summary: pa.Table
    """Mean and std per setting and method."""
    folder: Path | None


@contextlib.contextmanager
def _silent() -> Iterator[None]:
    from .cli.common import STATE

    saved = dict(STATE)
    STATE.update(quiet=True, json=False, silent=True)
    try:
        yield
    finally:
        STATE.clear()
        STATE.update(saved)


@contextlib.contextmanager
def _folder(out: str | Path | None) -> Iterator[tuple[Path, bool]]:
    if out is not None:
        yield Path(out), True
        return
    with tempfile.TemporaryDirectory(prefix="marops-") as tmp:
        yield Path(tmp) / "out", False


def _call(command: Callable[..., Any], **kwargs: Any) -> Any:
    """Run a command's function itself (not its error-to-exit-code wrapper), silently."""
    raw = getattr(command, "__wrapped__", command)
    for k in ("data", "out", "depots", "config", "fleet", "delivered"):
        if isinstance(kwargs.get(k), str):
            kwargs[k] = Path(kwargs[k])
    with _silent():
        return raw(**kwargs)


def read_lade(data: str | Path, *, year: int = 2022, strict: bool = False) -> pa.Table:
    """The kept rows of a LaDe export as a table (``order_id``, ``lng``, ``lat``,
    ``accept_time`` and ``delivery_time`` as local times, ``row``, ``weight_kg`` when the
    file has it); the rows dropped and why are in the metadata ``marops.drop_report``."""
    import pyarrow as pa

    from .config import DataConfig
    from .data.reader import read_lade as _read

    table = _read(Path(data), DataConfig(year=year, strict=strict))
    cols: dict[str, Any] = {
        "order_id": table.order_id.astype(str),
        "lng": table.lng,
        "lat": table.lat,
        "accept_time": pa.array(table.accept_s.astype("datetime64[s]")),  # local, naive
        "delivery_time": pa.array(table.delivery_s.astype("datetime64[s]")),
        "row": table.row,  # 1-based row in the file (header = row 1)
    }
    if table.weight_kg is not None:
        cols["weight_kg"] = table.weight_kg
    out = pa.table(cols)
    report = json.dumps({"drop_report": table.report.to_dict()})
    return out.replace_schema_metadata({"marops": report})


def segment(data: str | Path, *, out: str | Path | None = None, **options: Any) -> dict[str, Any]:
    """``marops segment``: the depots document (``depots.json``) as a dictionary.
    Options: ``dates``, ``n_depots``, ``method``, ``size_km``, ``center``, ``actions``,
    ``seed``, ``geojson``, ``plot``, ``year``, ``strict``, ``config``."""
    with _folder(None) as (tmp, _):
        path = Path(out) if out is not None else tmp.with_name("depots.json")
        _call(_cmd("segment"), data=data, out=path, **options)
        return dict(json.loads(path.read_text(encoding="utf-8")))


def plan_window(
    data: str | Path,
    depots: str | Path,
    date: str,
    window: int,
    *,
    out: str | Path | None = None,
    **options: Any,
) -> DayResult:
    """``marops plan-window``: one window's stops and routes, and its solver and
    window objective (``metrics``). Options: ``method`` (default ``marops``),
    ``drones``, ``fleet``, ``delivered``, ``policy``, ``alpha``, ``seed``, ``tz``,
    ``geojson``, ``config``, …"""
    import pyarrow.parquet as pq

    with _folder(out) as (folder, kept):
        _call(
            _cmd("plan-window"),
            data=data,
            depots=depots,
            date=str(date),
            window=int(window),
            out=folder,
            **options,
        )
        stops = pq.read_table(folder / "stops.parquet")
        routes = pq.read_table(folder / "routes.parquet")
        meta = json.loads(stops.schema.metadata[b"marops"])
        info = {"solver": meta.get("solver"), "objective": meta.get("objective")}
        return DayResult(stops, routes, info, folder if kept else None)


def replay_day(
    data: str | Path, date: str, *, out: str | Path | None = None, **options: Any
) -> DayResult:
    """``marops replay-day --date``: the day's stops, routes and metrics. Options:
    ``method`` (default ``marops``), ``depots``, ``n_depots``, ``drones``, ``policy``,
    ``alpha``, ``seed``, ``tz``, ``geojson``, ``plot``, ``force``, ``config``, …"""
    import pyarrow.parquet as pq

    with _folder(out) as (folder, kept):
        _call(_cmd("replay-day"), data=data, date=str(date), out=folder, **options)
        stops = pq.read_table(folder / "stops.parquet")
        routes = pq.read_table(folder / "routes.parquet")
        metrics = json.loads((folder / "metrics.json").read_text(encoding="utf-8"))["days"][0]
        return DayResult(stops, routes, metrics, folder if kept else None)


def evaluate(
    data: str | Path, *, out: str | Path | None = None, **options: Any
) -> EvaluationResult:
    """``marops evaluate``: per-day results and their summary. Options: ``methods``
    (comma-separated), ``dates``, ``split``, ``repeats``, ``drones``, ``alpha``,
    ``coverage``, ``n_depots`` (sweeps take "a,b,c" strings), ``workers``, ``plots``,
    ``config``, …"""
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    with _folder(out) as (folder, kept):
        _call(_cmd("evaluate"), data=data, out=folder, **options)
        results = pq.read_table(folder / "results.parquet")
        summary = pacsv.read_csv(folder / "summary.csv")
        return EvaluationResult(results, summary, folder if kept else None)


def _cmd(name: str) -> Callable[..., Any]:
    import importlib

    module, attr = {
        "segment": ("segment_cmd", "segment"),
        "plan-window": ("plan_window_cmd", "plan_window"),
        "replay-day": ("replay_cmd", "replay_day"),
        "evaluate": ("evaluate_cmd", "evaluate"),
    }[name]
    fn: Callable[..., Any] = getattr(importlib.import_module(f".cli.{module}", __package__), attr)
    return fn
