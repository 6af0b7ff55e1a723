"""What a report reads: the outputs an earlier command left in a folder (docs/outputs.md),
never anything else."""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

from ..data.jsonfile import first_line, parse_json
from ..errors import InputError
from ..io.paths import natural_key

T = TypeVar("T")

REPORT = "report.html"
"""The page's name in each output folder."""
_TIMES = ("window_start", "arrive_time")


@dataclass(frozen=True)
class RouteFiles:
    """A folder's stops and routes (rows with local times without their zone, as a
    clock shows them) and the metadata they carry."""

    stops: list[dict[str, Any]]
    routes: list[dict[str, Any]]
    meta: dict[str, Any]


def route_files(folder: Path) -> RouteFiles | None:
    """The stops and routes of ``folder`` (Parquet, else JSON); None when it has none."""
    if (folder / "routes.parquet").is_file():
        from ..data.arrow import read_parquet

        tables = [read_input(folder / f"{n}.parquet", read_parquet) for n in ("stops", "routes")]
        for name, table in zip(("stops", "routes"), tables, strict=True):
            _check_columns(table, name, folder / f"{name}.parquet")
        meta = table_meta(tables[1], folder / "routes.parquet")
        one_run(folder / "stops.parquet", table_meta(tables[0], folder / "stops.parquet"), meta)
        stops, routes = (t.to_pylist() for t in tables)
    elif (folder / "routes.json").is_file():
        docs = [_json(folder / f"{n}.json") for n in ("stops", "routes")]
        for name, doc in zip(("stops", "routes"), docs, strict=True):
            _check_rows(doc, name, folder / f"{name}.json")
        stops, routes, meta = docs[0]["stops"], docs[1]["routes"], docs[1].get("meta", {})
        one_run(folder / "stops.json", docs[0].get("meta", {}), meta)
    else:
        return None
    for row in (*stops, *routes):
        for k in _TIMES:
            if k in row and row[k] is not None:
                row[k] = _local(row[k])
    return RouteFiles(stops, routes, meta)


def _schema(name: str) -> Any:
    """The schema marops writes the route table ``name`` (``stops``, ``routes``) with."""
    from ..io.tables import routes_schema, stops_schema

    return stops_schema() if name == "stops" else routes_schema()


def _check_columns(table: Any, name: str, path: Path) -> None:
    """Each column of the route table ``name`` (docs/outputs.md) present with the type
    marops writes (a time stamp in any zone): an edited file is one line naming the file
    and its column, not an error of the page's making."""
    import pyarrow as pa

    expected = _schema(name)
    for field in expected:
        if field.name not in table.schema.names:
            raise InputError(
                f"has no column {field.name!r}: not as marops writes a {name} file "
                "(edited since, or of an older marops: replay again)",
                file=path,
                column=field.name,
            )
        got = table.schema.field(field.name).type
        stamp = pa.types.is_timestamp(got) and pa.types.is_timestamp(field.type)
        if got != field.type and not stamp:
            raise InputError(
                f"expected a column of {field.type}, got {got}: edited since marops wrote it",
                file=path,
                column=field.name,
            )


def _check_rows(doc: dict[str, Any], name: str, path: Path) -> None:
    """The rows of a ``--format json`` route file as marops writes them: each an object
    with every column of the table ``name``, a number where the column is one."""
    import pyarrow as pa

    rows = doc.get(name)
    if not isinstance(rows, list):
        raise InputError(f"expected a list of {name}, edited since marops wrote it", file=path)
    expected = _schema(name)
    numeric = {
        f.name for f in expected if pa.types.is_integer(f.type) or pa.types.is_floating(f.type)
    }
    for i, row in enumerate(rows):
        if not isinstance(row, dict):
            raise InputError("expected an object", file=path, column=f"{name}[{i}]")
        for field in expected:
            if field.name not in row:
                raise InputError(
                    f"has no {field.name!r}: not as marops writes a {name} file",
                    file=path,
                    column=f"{name}[{i}].{field.name}",
                )
            value = row[field.name]
            number = isinstance(value, int | float) and not isinstance(value, bool)
            if field.name in numeric and value is not None and not number:
                raise InputError(
                    f"expected a number, got {value!r}: edited since marops wrote it",
                    file=path,
                    column=f"{name}[{i}].{field.name}",
                )


_RUN_KEYS = ("version", "command", "config", "input", "policy", "method", "seed", "day", "frame")
"""What the metadata of one run's files share (docs/outputs.md): files of a folder that
differ in one of them were written by different runs."""


def one_run(path: Path, meta: Any, routes_meta: dict[str, Any]) -> None:
    """Refuse the file ``path`` whose marops metadata ``meta`` is not of the run that
    wrote the folder's routes (``routes_meta``): a page would mix two runs' figures. A
    file without metadata (written by hand, or an older marops) is not checked."""
    if not isinstance(meta, dict):
        return
    for key in _RUN_KEYS:
        if key in meta and key in routes_meta and meta[key] != routes_meta[key]:
            raise InputError(
                f"is not of the run that wrote the routes beside it (its {key!r} differs): "
                "keep each run's files in a folder of their own, or run it again",
                file=path,
                column=key,
            )


def _local(value: Any) -> dt.datetime:
    """A time of day in the data's zone, without the zone (the files store local times)."""
    t = dt.datetime.fromisoformat(value) if isinstance(value, str) else value
    return t.replace(tzinfo=None)


def metrics(folder: Path) -> dict[str, Any] | None:
    """``folder/metrics.json`` (None when absent); a day's metric the page shows as a
    number that is none (edited to text) is one line naming the file and key."""
    from math import inf

    from ..config import clipped
    from ..sim.metrics import DAY_METRICS

    path = folder / "metrics.json"
    if not path.is_file():
        return None
    doc = _json(path)
    numbers = {m.name for m in DAY_METRICS}
    days = doc.get("days")
    records = [(f"days[{i}].", d) for i, d in enumerate(days)] if isinstance(days, list) else []
    if isinstance(doc.get("total"), dict):
        records.append(("total.", doc["total"]))
    for at, record in records:
        if not isinstance(record, dict):
            raise InputError("expected a day's metrics (an object)", file=path, column=at[:-1])
        for key, value in record.items():
            number = isinstance(value, int | float) and not isinstance(value, bool)
            # Every day metric is finite as marops writes it, and all but G not negative.
            low = -inf if key == "objective_g_mj" else 0.0
            if key in numbers and value is not None and (not number or not low <= value < inf):
                kind = "a number" if not number else "a finite number"
                kind += " of at least 0" if number and low == 0 else ""
                raise InputError(
                    f"expected {kind}, got {clipped(repr(value))}: edited since marops wrote it",
                    file=path,
                    column=at + key,
                )
    return doc


def read_input(path: Path, read: Callable[[Path], T]) -> T:
    """``read(path)``; a file that cannot be read (missing, damaged: Arrow's and JSON's
    errors are ValueErrors) is one line naming it."""
    if not path.exists():  # Arrow's error is the bare path
        raise InputError(
            "not found: the report reads it with the folder's other outputs", file=path
        )
    if not path.is_file():  # a pipe nobody writes would block for ever, a device never end
        raise InputError(
            "is not a regular file (a folder, a pipe or a device): not an output marops wrote",
            file=path,
        )
    try:
        return read(path)
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot be read for the report ({first_line(exc)})", file=path) from None


def table_meta(table: Any, path: Path) -> dict[str, Any]:
    """The ``marops`` metadata of ``table``, read from ``path`` ({} when it has none)."""
    meta = read_input(
        path, lambda p: parse_json((table.schema.metadata or {}).get(b"marops", b"{}"))
    )
    if not isinstance(meta, dict):
        raise InputError("its marops metadata is not a JSON object", file=path)
    return meta


def _json(path: Path) -> dict[str, Any]:
    doc = read_input(path, lambda p: parse_json(p.read_text(encoding="utf-8")))
    if not isinstance(doc, dict):
        raise InputError("is not a marops output (a JSON object expected)", file=path)
    return doc


def is_evaluation(folder: Path) -> bool:
    """``folder`` holds an evaluation's tables (``marops evaluate --out``)."""
    return (folder / "summary.csv").is_file() and (folder / "results.parquet").is_file()


def sub_reports(folder: Path) -> list[Path]:
    """The folders below a several-day or city run's ``folder`` that hold a day or a hub
    (``YYYY-MM-DD/``, ``hub-<id>/``), in name order with numbers by value (hub-9 before
    hub-10)."""
    subs = [p for p in sorted(folder.iterdir(), key=natural_key) if p.is_dir()]
    return [p for p in subs if (p / "metrics.json").is_file() or route_files_exist(p)]


def route_files_exist(folder: Path) -> bool:
    return any((folder / f"routes.{f}").is_file() for f in ("parquet", "json"))
