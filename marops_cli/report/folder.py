"""What a report reads: the outputs an earlier command left in a folder (docs/outputs.md),
never anything else."""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

from ..data.jsonfile import first_line, parse_json
from ..errors import InputError, quoted
from ..io.paths import natural_key
from .checks import (
    EDITED,
    Col,
    Kind,
    cell_fits,
    check_cell,
    check_meta,
    check_table,
    meta_error,
    require_columns,
)

T = TypeVar("T")

REPORT = "report.html"
"""The page's name in each output folder."""
_TIMES = ("window_start", "arrive_time")
"""The times of a stop (a route's: its window's start)."""


@dataclass(frozen=True)
class RouteFiles:
    """A folder's stops and routes (rows with local times without their zone, as a
    clock shows them) and the metadata they carry; ``paths``: the stops and routes files
    they were read from."""

    stops: list[dict[str, Any]]
    routes: list[dict[str, Any]]
    meta: dict[str, Any]
    paths: tuple[Path, ...] = ()


def route_files(folder: Path) -> RouteFiles | None:
    """The stops and routes of ``folder`` (Parquet, else JSON); None when it has none.
    Each value the page uses is checked as marops writes it (:mod:`.checks`)."""
    if (folder / "routes.parquet").is_file():
        from ..config import MAX_DAY_ROUTES, MAX_DAY_STOPS

        paths = tuple(folder / f"{n}.parquet" for n in ("stops", "routes"))
        most = (MAX_DAY_STOPS, MAX_DAY_ROUTES)
        read = [rows_at_most(n, "a day's replay writes") for n in most]
        tables = [read_input(path, r) for path, r in zip(paths, read, strict=True)]
        for name, table, path in zip(("stops", "routes"), tables, paths, strict=True):
            _check_columns(table, name, path)
            check_table(table, path, _columns(name), f"a {name} file", redo=_REDO)
        meta = table_meta(tables[1], paths[1])
        one_run(paths[0], table_meta(tables[0], paths[0]), meta)
        stops, routes = (t.to_pylist() for t in tables)
    elif (folder / "routes.json").is_file():
        paths = tuple(folder / f"{n}.json" for n in ("stops", "routes"))
        from ..io.routejson import read_route_json

        docs = [_json(path, read_route_json) for path in paths]
        for name, doc, path in zip(("stops", "routes"), docs, paths, strict=True):
            _check_rows(doc, name, path)
            if not isinstance(doc.get("meta", {}), dict):
                raise InputError(
                    f"expected an object, got {quoted(doc['meta'])}: {EDITED}",
                    file=path,
                    column="meta",
                )
        stops, routes, meta = docs[0]["stops"], docs[1]["routes"], docs[1].get("meta", {})
        one_run(paths[0], docs[0].get("meta", {}), meta)
    else:
        return None
    check_route_meta(meta, paths[1])
    for rows, keys in ((stops, _TIMES), (routes, _TIMES[:1])):
        for row in rows:
            for k in keys:
                row[k] = _local(row[k])
    _check_once(stops, routes, paths)
    _check_flown(stops, routes, paths)
    return RouteFiles(stops, routes, meta, paths)


_REDO = "replay again"
_DEPOTS = frozenset({"start", "end"})
_KINDS = ("start", "customer", "end")
_EMPTY = {
    "stops": {
        "depot": frozenset({"customer"}),
        **dict.fromkeys(("order_id", "weight_kg", "due_window", "delay_h"), _DEPOTS),
    },
    "routes": {},
}
"""Columns that are empty (null) in some rows as marops writes them (docs/outputs.md):
a stop's depot for a customer, its parcel's figures for a depot."""


def _schema(name: str) -> Any:
    """The schema marops writes the route table ``name`` (``stops``, ``routes``) with."""
    from ..io.tables import routes_schema, stops_schema

    return stops_schema() if name == "stops" else routes_schema()


def _columns(name: str) -> dict[str, Col]:
    """What each column of the route table ``name`` holds (docs/outputs.md)."""
    columns = {}
    for field in _schema(name):
        values = _KINDS if field.name == "kind" else ()
        empty = _EMPTY[name].get(field.name, False)
        columns[field.name] = Col(_kind(field.type), empty=empty, values=values)
    return columns


def _kind(t: Any) -> Kind:
    """What a value of the Arrow type ``t`` is, as :class:`~.checks.Col` says it."""
    import pyarrow as pa

    if pa.types.is_integer(t):
        return "int"
    if pa.types.is_floating(t):
        return "number"
    if pa.types.is_timestamp(t):
        return "time"
    return "date" if pa.types.is_date(t) else "text"


def _check_columns(table: Any, name: str, path: Path) -> None:
    """Each column of the route table ``name`` (docs/outputs.md) present with the type
    marops writes (a time stamp in any zone): an edited file is one line naming the file
    and its column, not an error of the page's making."""
    import pyarrow as pa

    expected = _schema(name)
    require_columns(table, path, expected.names, f"a {name} file", redo=_REDO)
    for field in expected:
        got = table.schema.field(field.name).type
        stamp = pa.types.is_timestamp(got) and pa.types.is_timestamp(field.type)
        if got != field.type and not stamp:
            raise InputError(
                f"expected a column of {field.type}, got {got}: {EDITED}",
                file=path,
                column=field.name,
            )


def _check_rows(doc: dict[str, Any], name: str, path: Path) -> None:
    """The rows of a ``--format json`` route file as marops writes them: each an object
    with every column of the table ``name``, each value of the column's type (a number,
    text, an ISO time or date; empty only where marops leaves it so), a stop's kind one
    of :data:`_KINDS`."""
    rows = doc.get(name)
    if not isinstance(rows, list):
        raise InputError(f"expected a list of {name}, {EDITED}", file=path)
    columns = _columns(name)
    for i, row in enumerate(rows):
        if not isinstance(row, dict):
            raise InputError("expected an object", file=path, column=f"{name}[{i}]")
        for key in columns:
            if key not in row:
                raise InputError(
                    f"has no {key!r}: not as marops writes a {name} file",
                    file=path,
                    column=f"{name}[{i}].{key}",
                )
        kind = row.get("kind")
        for key, col in columns.items():
            check_cell(row[key], col, path, f"{name}[{i}].{key}", kind)


def _check_once(
    stops: list[dict[str, Any]], routes: list[dict[str, Any]], paths: tuple[Path, ...]
) -> None:
    """A route per drone and window, a stop per place in its route, as marops writes
    them: a row repeated (rows copied within the file) is one line naming it, where the
    map would draw each of a drone's copies with every copy of its stops (a file of a
    few hundred kilobytes held minutes and gigabytes)."""
    tables = (("stops", stops, ("window", "drone", "seq")), ("routes", routes, ("window", "drone")))
    for (name, rows, keys), path in zip(tables, paths, strict=True):
        seen: dict[tuple[Any, ...], int] = {}
        for i, row in enumerate(rows):
            key = tuple(row[k] for k in keys)
            first = seen.setdefault(key, i)
            if first == i:
                continue
            json_file = path.suffix == ".json"
            where: dict[str, Any] = {"column": f"{name}[{i}]"} if json_file else {"row": i + 2}
            said = ", ".join(f"{k} {v}" for k, v in zip(keys, key, strict=True))
            again = f"{name}[{first}]" if json_file else f"row {first + 2}"
            raise InputError(
                f"repeats {again} ({said}): marops writes one row of each: {EDITED}",
                file=path,
                **where,
            )


def _check_flown(
    stops: list[dict[str, Any]], routes: list[dict[str, Any]], paths: tuple[Path, ...]
) -> None:
    """Every route flown has its stops in the stops file (the map draws them)."""
    have = {(s["window"], s["drone"]) for s in stops}
    for i, r in enumerate(routes):
        if flown(r) and (r["window"], r["drone"]) not in have:
            where: dict[str, Any] = (
                {"column": f"routes[{i}]"} if paths[1].suffix == ".json" else {"row": i + 2}
            )
            raise InputError(
                f"drone {r['drone']} flies in window {r['window']}, but {paths[0].name} has no "
                f"stops of that flight: {EDITED}",
                file=paths[1],
                **where,
            )


def flown(route: dict[str, Any]) -> bool:
    """A route that is drawn: it delivers a parcel or moves its drone to another depot."""
    return route["n_parcels"] > 0 or route["start_depot"] != route["end_depot"]


_ROUTE_META: dict[str, type | tuple[type, ...]] = {
    "day": str,
    "method": str,
    "frame": dict,
    "solver": dict,
    "objective": dict,
    "config": dict,
}
"""The keys of a route file's marops metadata the page reads, and their types."""


def check_route_meta(meta: dict[str, Any], path: Path) -> None:
    """The route file's metadata the page reads (its title, the study square, the
    window's plan, the window length of the config) as marops writes it."""
    check_meta(meta, path, _ROUTE_META)
    frame = meta.get("frame")
    if frame:
        for key in ("center_lng", "center_lat", "size_km"):
            value = frame.get(key)
            if not cell_fits(value, Col("number")):
                raise meta_error(path, f"frame.{key}", "a finite number", value)
    data = (meta.get("config") or {}).get("data")
    if data is None:
        return
    if not isinstance(data, dict):
        raise meta_error(path, "config.data", "an object", data)
    for key, col in (
        ("window_min", Col("number", empty=True)),
        ("windows", Col("int", empty=True)),
        ("service_start", Col("text", empty=True)),
        ("service_end", Col("text", empty=True)),
    ):
        if not cell_fits(data.get(key), col):
            raise meta_error(path, f"config.data.{key}", col.expected(), data.get(key))


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
    """A time of day in the data's zone, without the zone (the files store local times;
    a JSON file's as ISO text, checked by :func:`_check_rows`)."""
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
    # A page reads it beside a day's routes, or over several days or a city; another
    # tool's metrics.json (a folder of one's own among the days) is left as it is.
    used = "total" in doc or "city" in doc or route_files_exist(folder)
    if used:
        check_meta(doc, path, {"days": list, "total": dict, "city": dict}, at="")
    days = doc.get("days")
    records = [(f"days[{i}].", d) for i, d in enumerate(days)] if isinstance(days, list) else []
    if isinstance(doc.get("total"), dict):
        records.append(("total.", doc["total"]))
    for at, record in records:
        if not isinstance(record, dict):
            raise InputError("expected a day's metrics (an object)", file=path, column=at[:-1])
        if used and at.startswith("days"):  # a day's record names its day and method
            for key, col in _DAY_KEYS.items():
                if key not in record and not col.empty:
                    raise InputError(f"has no {key!r}: {EDITED}", file=path, column=at + key)
                check_cell(record.get(key), col, path, at + key)
        for key, value in record.items():
            number = isinstance(value, int | float) and not isinstance(value, bool)
            # Every day metric is finite as marops writes it, and all but G not negative.
            low = -inf if key == "objective_g_mj" else 0.0
            if key in numbers and value is not None and (not number or not low <= value < inf):
                kind = "a number" if not number else "a finite number"
                kind += " of at least 0" if number and low == 0 else ""
                raise InputError(
                    f"expected {kind}, got {clipped(repr(value))}: {EDITED}",
                    file=path,
                    column=at + key,
                )
    return doc


_DAY_KEYS = {"day": Col("text"), "method": Col("text"), "hub": Col("int", empty=True)}
"""What a day's record in ``metrics.json`` is named by: its day, method and hub (0, or
none, for a single study area)."""


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


def rows_at_most(most: int, writes: str) -> Callable[[Path], Any]:
    """A reader (for :func:`read_input`) of a Parquet output of at most ``most`` rows,
    as many as ``writes`` says marops writes at most (``a day's replay writes``): a file
    of more, which no run writes, is refused by its footer before any row is read (a
    megabyte of repeated rows unpacks to gigabytes)."""
    from ..data.arrow import parquet_rows, read_parquet

    def read(path: Path) -> Any:
        rows = parquet_rows(path)
        if rows > most:
            raise InputError(
                f"holds {rows:,} rows, more than the {most:,} {writes}: {EDITED}",
                file=path,
            )
        return read_parquet(path)

    return read


def table_meta(table: Any, path: Path) -> dict[str, Any]:
    """The ``marops`` metadata of ``table``, read from ``path`` ({} when it has none)."""
    meta = read_input(
        path, lambda p: parse_json((table.schema.metadata or {}).get(b"marops", b"{}"))
    )
    if not isinstance(meta, dict):
        raise InputError("its marops metadata is not a JSON object", file=path)
    return meta


def _json(path: Path, read: Callable[[Path], Any] | None = None) -> dict[str, Any]:
    """The JSON object ``path`` holds (:func:`read_input`), read by ``read`` (a route
    file's: :func:`~marops_cli.io.routejson.read_route_json`), else whole (``metrics.json``)."""
    doc = read_input(path, read or (lambda p: parse_json(p.read_text(encoding="utf-8"))))
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


def unfinished_parts(folder: Path) -> list[Path]:
    """The day and hub folders (``YYYY-MM-DD/``, ``hub-<id>/``) of a several-day or city
    run that stopped before writing its ``metrics.json`` over them (a run killed half-way
    keeps every day it finished): ``folder``'s, when it holds no output of its own (no
    ``metrics.json``, no routes); empty for any other folder."""
    if (folder / "metrics.json").exists() or route_files_exist(folder):
        return []
    subs = sorted(folder.iterdir(), key=natural_key)
    return [p for p in subs if _part_name(p.name) and p.is_dir()]


def _part_name(name: str) -> bool:
    """Whether ``name`` is a day's folder (``2022-08-11``) or a hub's (``hub-3``)."""
    if name.startswith("hub-"):
        return name.removeprefix("hub-").isdecimal()
    try:
        return dt.date.fromisoformat(name).isoformat() == name
    except ValueError:
        return False


def route_files_exist(folder: Path) -> bool:
    return any((folder / f"routes.{f}").is_file() for f in ("parquet", "json"))
