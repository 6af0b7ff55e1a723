"""The Python API: the use cases as functions, for notebooks and scripts.

Each function runs the use case its command runs (marops_cli/app/), with the
commands' flags as keyword arguments (``drones=16``, ``alpha=0.2``,
``config="planner.toml"``). ``data`` is a LaDe export's path, or its rows in memory
as a pandas ``DataFrame`` or a ``pyarrow.Table`` with the export's columns (read and
checked as a file is; errors name ``DataFrame`` or ``Table``). Results are in memory:
tables as ``pyarrow.Table`` (``.to_pandas()``, ``polars.from_arrow``) carrying the
files' ``marops`` metadata, metrics as dictionaries. Nothing is written unless
``out`` is given, then exactly the files its command writes there (``plot``,
``geojson`` and ``report`` ask for files: without ``out`` they are an InputError);
nothing is printed (warnings are :mod:`warnings`); errors are raised as
:class:`marops_cli.errors.InputError` (bad input) or
:class:`marops_cli.errors.MaropsError`. Depots segmented from a file are cached as the
commands cache them (docs/outputs.md "Depots cache") by a call given ``out``; without
``out`` only when ``MAROPS_CACHE_DIR`` names the cache's folder; from data in memory
never (docs/decisions.md, "Application layer").

    from marops_cli import api as marops

    depots = marops.segment("lade.csv", out="out/depots.json", dates="0801..0810")
    day = marops.replay_day(frame, date="0811", depots=depots)  # or "out/depots.json"
    day.metrics["avg_delay_h"], day.routes.to_pandas()
"""

from __future__ import annotations

import contextlib
import datetime as dt
import functools
import inspect
import json
import numbers
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, TypeVar, Union

if TYPE_CHECKING:  # pyarrow loads with the first call, so `import marops_cli` stays light
    import pyarrow as pa

    from .segment.depots import Depots


__all__ = [
    "DayResult",
    "EvaluationResult",
    "evaluate",
    "plan_window",
    "read_lade",
    "replay_day",
    "report",
    "segment",
]


@dataclass(frozen=True)
class DayResult:
    """A planned window or a replayed day: its stops and routes tables and metrics."""

    stops: pa.Table
    routes: pa.Table
    metrics: dict[str, Any]
    """The day's ``metrics.json`` record (``replay_day``), or the window's solver and
    objective (``plan_window``: ``objective`` holds the window objective ``J`` and its
    part ``G`` in joules, not the MJ of ``metrics.json``; ``energy_j``, its routes' energy
    in joules; ``served`` and ``pending``, counts of requests)."""
    folder: Path | None
    """Where the files are (None when nothing was written)."""
    city: dict[str, Any] | None = None
    """A city's day (``area="hubs"``, ``hubs``): its coverage, ``metrics.json``'s
    ``city`` (docs/outputs.md, "Hubs"); None for one study area."""


@dataclass(frozen=True)
class EvaluationResult:
    """An evaluation's tables (docs/outputs.md, "Evaluation")."""

    results: pa.Table
    """One row per setting × method × day × repeat (docs/outputs.md, "Evaluation")."""
    summary: pa.Table
    """Mean and std per setting and method."""
    folder: Path | None
    paired: pa.Table | None = None
    """With ``against``: each method's per-day difference to it, with a bootstrap 95 %
    interval (``paired.csv``); None without."""
    frontier: pa.Table | None = None
    """With two or more values of ``alpha`` (or ``frontier=True``): each method's
    operating point per α, dominated ones marked (``frontier.csv``); None without."""


def _path(value: str | Path | None) -> Path | None:
    return Path(value) if value is not None else None


# --- argument checks ---------------------------------------------------------------
# A wrong argument type is bad input like a bad flag: one InputError naming the keyword,
# not a TypeError from deep inside. Each parameter's annotation (an option of the table
# in marops_cli/app/options.py: its type there) is checked as a pydantic type made at the
# first call: numbers as numbers or their text (never True or False), a path as a
# non-empty str or PathLike, lists where the command takes "a,b,c".


def _is_int(v: Any) -> bool:
    return isinstance(v, numbers.Integral) and not isinstance(v, bool)


def _is_real(v: Any) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool)


def _numpy_day(v: Any) -> dt.date | None:
    """A numpy ``datetime64`` (a frame's ``.unique()`` gives them) as its day; None for
    anything else, NaT included."""
    if type(v).__name__ != "datetime64" or not hasattr(v, "astype"):
        return None
    day = v.astype("datetime64[D]").item()
    return day if isinstance(day, dt.date) else None


def _item(v: Any) -> str | None:
    """One element of a list keyword as its command spells it (None: not one)."""
    if (day := _numpy_day(v)) is not None:
        v = day
    if isinstance(v, str):
        return v
    if isinstance(v, dt.date):
        try:
            return v.strftime("%Y-%m-%d")
        except ValueError:  # pandas' NaT is a datetime of no day
            return None
    if _is_real(v):
        return str(v)
    return None


def _text(v: Any) -> str | None:
    """A list keyword's value as its flag spells it ("a,b"): a string, a date, a number
    or a list or tuple of them; None for anything else."""
    items = [v] if isinstance(v, str | dt.date) or _is_real(v) else v
    if _numpy_day(v) is not None:
        items = [v]
    elif getattr(v, "ndim", None) == 1 and hasattr(v, "__iter__"):  # an array, Series, Index
        items = list(v)
    if not isinstance(items, list | tuple) or not items:
        return None
    parts = [_item(x) for x in items]
    return None if None in parts else ",".join(p for p in parts if p is not None)


def _as_number(kind: type) -> Callable[[Any], Any]:
    """A number of ``kind`` from any number but True or False, or from its text; else the
    value as it is (for the strict type to refuse)."""

    def convert(v: Any) -> Any:
        if (_is_int if kind is int else _is_real)(v):
            return kind(v)
        if isinstance(v, str):
            try:
                return kind(v.strip())
            except ValueError:
                return v
        return v

    return convert


def _as_bool(v: Any) -> Any:
    """numpy's True or False (a frame's ``.any()`` gives them) as Python's; else the value
    as it is (for the strict type to refuse)."""
    kind = type(v)
    if kind.__module__ == "numpy" and kind.__name__ in ("bool", "bool_"):
        return bool(v)
    return v


def _refused(v: Any) -> Any:
    raise ValueError("refused")


def _only(accept: Callable[[Any], bool]) -> Callable[[Any], Any]:
    return lambda v: v if accept(v) else _refused(v)


def _a_path(v: Any) -> bool:
    return isinstance(v, str | os.PathLike) and os.fspath(v) != ""  # "": the current folder


def _a_day(v: Any) -> dt.date:
    """``date``'s day of a date, a datetime (a pandas Timestamp) or a numpy datetime64."""
    if (day := _numpy_day(v)) is not None:
        return day
    if isinstance(v, dt.datetime):
        return v.date()
    return v if isinstance(v, dt.date) else _refused(v)


def _simple_kinds() -> dict[Any, tuple[Any, str]]:
    """The pydantic type of each plain annotation and how an error says it, in the order
    an error lists them."""
    from pydantic import (
        BeforeValidator,
        PlainValidator,
        Strict,
        StrictBool,
        StrictFloat,
        StrictInt,
        StrictStr,
    )

    real = Annotated[StrictFloat, BeforeValidator(lambda v: float(v) if _is_real(v) else v)]
    pair = Annotated[
        tuple[real, real],
        Strict(),  # a tuple or a list, not any iterable
        BeforeValidator(lambda v: tuple(v) if isinstance(v, list) else v),
    ]
    return {
        Path: (Annotated[Any, PlainValidator(_only(_a_path))], "a path"),
        tuple[float, float]: (pair, "a (lng, lat) pair"),
        bool: (Annotated[StrictBool, BeforeValidator(_as_bool)], "True or False"),
        int: (Annotated[StrictInt, BeforeValidator(_as_number(int))], "an integer"),
        float: (Annotated[StrictFloat, BeforeValidator(_as_number(float))], "a number"),
        dt.date: (Annotated[dt.date, PlainValidator(_a_day)], "a datetime.date"),
        str: (StrictStr, "a string"),
    }


@functools.cache
def _kind(hint: Any) -> tuple[Any, str]:
    """The pydantic check of an annotation (``int | None``), as a TypeAdapter, and what an
    error says it expects. Text stays text where the annotation takes a str (``hubs``:
    ``"3"`` or ``3``); a str or a PathLike is a path where it takes a ``Path``."""
    import typing
    from collections.abc import Mapping

    from pydantic import Field, PlainValidator, TypeAdapter

    from .segment.depots import Depots

    def only(accept: Callable[[Any], bool]) -> Any:
        return Annotated[Any, PlainValidator(_only(accept))]

    members = list(typing.get_args(hint)) if _is_union(hint) else [hint]
    optional = type(None) in members
    members = [m for m in members if m is not type(None)]
    simple = _simple_kinds()
    if Any in members:
        return TypeAdapter(Any), "anything"
    if any(typing.get_origin(m) is list for m in members):  # the flag's "a,b"
        kinds = [only(lambda v: _text(v) is not None)]
        said = "a string like 'a,b' or a non-empty list"
    elif Depots in members:  # a depots file, or the depots in memory
        kinds = [only(_a_path), only(lambda v: isinstance(v, Mapping | Depots))]
        said = "a path or the depots segment() returns"
    else:
        if Path in members:
            members = [m for m in members if m is not str]
        kinds = [simple[m][0] for m in sorted(members, key=lambda m: m is not str)]
        said = " or ".join(text for m, (_, text) in simple.items() if m in members)
        if dt.date in members:
            said = "a date like '0820', 820 or a datetime.date"
    one: Any = kinds[0]
    if len(kinds) > 1:  # the first that takes the value, in order: text as it is, numbers
        one = Annotated[Union[tuple(kinds)], Field(union_mode="left_to_right")]  # noqa: UP007
    return TypeAdapter(one | None if optional else one), said


def _is_union(hint: Any) -> bool:
    import types
    import typing

    return typing.get_origin(hint) in (typing.Union, types.UnionType)


class _Checks:
    """An API function's parameters as its callers see them (the table's options of its
    use case in), and each one's pydantic check, made at its first call."""

    def __init__(self, fn: Callable[..., Any], use: str | None) -> None:
        self.fn, self.use = fn, use
        self.own = inspect.signature(fn)

    def signature(self) -> inspect.Signature:
        if self.use is None:
            return self.own
        from .app.options import with_options

        return with_options(self.own, self.use, _keyword, ("config",))

    @functools.cached_property
    def hints(self) -> dict[str, Any]:
        import typing

        import pyarrow as pa

        from .segment.depots import Depots

        return typing.get_type_hints(self.fn, localns={"pa": pa, "Depots": Depots})

    def check(self, param: inspect.Parameter, value: Any) -> Any:
        """``value`` as parameter ``param`` takes it (a number from its text, a pair a
        tuple), or the InputError naming the keyword."""
        from pydantic import ValidationError

        from .errors import InputError

        name = param.name
        adapter, expects = _kind(self.hints.get(name, param.annotation))
        try:
            return adapter.validate_python(value)
        except ValidationError:
            raise InputError(
                f"{self.fn.__name__}(): {name} expects {expects}, "
                f"got {type(value).__name__} {_shown(value)}"
            ) from None


def _keyword(spec: Any) -> inspect.Parameter:
    """The API's keyword of a table option: its type (or the wider one the API takes),
    None (the config's value) unless given; a switch off unless given."""
    kind = spec.api_type or spec.type
    return inspect.Parameter(
        spec.param,
        inspect.Parameter.KEYWORD_ONLY,
        default=False if spec.switch else None,
        annotation=kind if spec.switch else kind | None,
    )


F = TypeVar("F", bound=Callable[..., Any])


def _checked(use: str | None = None) -> Callable[[F], F]:
    """Check a function's arguments against its annotations before it runs (see above);
    with ``use``, it takes the table's options of that use case (marops_cli/app/options.py)
    as keywords too, gathered in its ``**options``. A path the system cannot look up (a
    name too long, a loop of links) is an InputError too. An error naming an option names
    it by its keyword (``alpha``), where the command line names its flag (``--alpha``;
    marops_cli/errors.py)."""

    def decorate(fn: F) -> F:
        checks = _Checks(fn, use)

        @functools.wraps(fn)
        def call(*args: Any, **kwargs: Any) -> Any:
            from .errors import InputError, bad_path, keyword
            from .workers.pool import not_in_a_starting_worker

            # A worker importing a script without a main guard stops at its first call
            # (the parent says why), not at the one that asks for workers: it would run
            # what comes before that, and the pool start another in its place, for ever.
            not_in_a_starting_worker()
            sig = checks.signature()
            try:
                bound = sig.bind(*args, **kwargs)
            except TypeError as exc:
                raise InputError(f"{fn.__name__}(): {exc}{_did_you_mean(sig, kwargs)}") from None
            for name, value in list(bound.arguments.items()):
                bound.arguments[name] = checks.check(sig.parameters[name], value)
            try:
                return fn(*bound.args, **_gathered(use, bound.kwargs, checks.own))
            except InputError as exc:
                exc.respell(keyword)
                raise
            except OSError as exc:  # a path the system cannot look up is bad input, as for a flag
                bad = bad_path(exc)
                if bad is None:
                    raise
                raise bad from None

        if use is not None:
            from .app.options import LiveSignature

            call.__signature__ = LiveSignature(checks.signature)  # type: ignore[attr-defined]
        return call  # type: ignore[return-value]

    return decorate


def _gathered(use: str | None, kwargs: dict[str, Any], own: inspect.Signature) -> dict[str, Any]:
    """A call's keyword arguments as the function takes them: the table's options of
    ``use`` gathered in its ``**options``."""
    if use is None:
        return kwargs
    from .app.options import split_options

    mine, options = split_options(use, kwargs, own)
    clash = set(mine) & set(options)
    if clash:  # a table option named like one of the function's own parameters
        raise TypeError(f"options named like parameters: {sorted(clash)}")
    return {**mine, **options}


def _did_you_mean(sig: inspect.Signature, kwargs: dict[str, Any]) -> str:
    """`` (did you mean method?)`` for a mistyped keyword, as a mistyped flag is
    answered; empty when nothing is close."""
    import difflib

    names = [n for n in sig.parameters if n not in ("data", "args", "kwargs")]
    for key in kwargs:
        if key not in sig.parameters:
            close = difflib.get_close_matches(key, names, n=3)
            if close:
                return f" (did you mean {' or '.join(close)}?)"
    return ""


def _files_asked(fn: str, out: Any, **asked: bool) -> None:
    """Refuse a keyword that asks for a file (``plot``, ``geojson``, ``report``) without
    ``out``: nothing is written without it, so the figure or map asked for would be
    silently missing (and nothing is drawn to find that out)."""
    from .errors import InputError

    if out is None:
        for name, wanted in asked.items():
            if wanted:
                raise InputError(
                    f"{fn}(): {name}=True writes files into out, and nothing is written "
                    "without it; pass out (a folder) or leave it False"
                )


@contextlib.contextmanager
def _one_call(force: bool, out: Any) -> Iterator[None]:
    """One call's run: its outputs may replace files marops did not write with ``force``;
    without ``out`` it writes nothing, the depots cache included unless
    ``MAROPS_CACHE_DIR`` names the cache's folder (docs/outputs.md, "Depots cache")."""
    from .io.ownership import replacing_foreign_files
    from .segment.cache import cache_named_only

    with replacing_foreign_files(force), cache_named_only(out is None):
        yield


def _given(options: dict[str, Any], **more: Any) -> dict[str, Any]:
    """The options and keywords a call gave (not None, a switch not False), by name."""
    return {name: v for name, v in {**options, **more}.items() if v is not None and v is not False}


def _shown(value: Any) -> str:
    from .config import clipped

    return clipped(" ".join(repr(value).split()))  # one line, a Series' repr too


@_checked()
def read_lade(
    data: Any, *, year: int = 2022, strict: bool = False, tz: str | None = None
) -> pa.Table:
    """The kept rows of a LaDe export (a path, a DataFrame or a Table) as a table
    (``order_id``, ``lng``, ``lat``, ``accept_time`` and ``delivery_time``, ``row``,
    ``weight_kg`` when the data has it); the rows dropped and why are in the metadata
    ``marops.drop_report``. The times are the data's local times with their zone ``tz``
    (default ``Asia/Shanghai``, as LaDe's are): ``timestamp[s, tz=…]``, like every
    output's times (docs/outputs.md, "Types")."""
    import pyarrow as pa
    import pyarrow.compute as pc
    from pydantic import ValidationError

    from .app.inputs import read_data
    from .config import DataConfig, validation_message
    from .errors import InputError

    try:
        cfg = DataConfig(year=year, strict=strict, **({"tz": tz} if tz is not None else {}))
    except ValidationError as exc:
        raise InputError(f"read_lade(): {validation_message(exc)}") from None
    table = read_data(data, cfg)

    def local(seconds: Any, at: Any) -> pa.Array:
        # The instants where the file's times carried their zone (``at``); else the
        # reader's seconds are wall-clock times of the zone, and a time a clock change
        # makes ambiguous or skips is taken as the earlier one, as the outputs take it.
        if at is not None:
            return pa.array(at, pa.timestamp("s", tz="UTC")).cast(pa.timestamp("s", tz=cfg.tz))
        wall = pa.array(seconds.astype("datetime64[s]"))
        return pc.assume_timezone(wall, cfg.tz, ambiguous="earliest", nonexistent="earliest")

    cols: dict[str, Any] = {
        "order_id": table.order_id.astype(str),
        "lng": table.lng,
        "lat": table.lat,
        "accept_time": local(table.accept_s, table.accept_at),
        "delivery_time": local(table.delivery_s, table.delivery_at),
        "row": table.row,  # 1-based row in the file (header = row 1)
    }
    if table.weight_kg is not None:
        cols["weight_kg"] = table.weight_kg
    out = pa.table(cols)
    report = json.dumps({"drop_report": table.report.to_dict()})
    return out.replace_schema_metadata({"marops": report})


@_checked("segment")
def segment(
    data: Any,
    *,
    out: str | Path | None = None,
    dates: str | list[str] | None = None,
    geojson: bool = False,
    plot: bool = False,
    hubs: str | int | None = None,
    force: bool = False,
    config: str | Path | None = None,
    method: str | None = None,
    **options: Any,
) -> dict[str, Any]:
    """``marops segment``: the depots document (``depots.json``; with ``hubs``, the
    hubs file) as a dictionary, written to ``out`` when given (the hubs file with its
    GeoJSON beside it, as ``segment --hubs`` writes). The depots document is taken
    wherever a depots file is (``plan_window``, ``replay_day``, ``report``). Its options
    (``n_depots``, ``segmentation``, ``seed``, …) are those of the command; ``method`` is
    the former name of ``segmentation`` (a DeprecationWarning)."""
    from .app.options import hubs_options, planner_config
    from .app.segment import refuse_with_hubs, segment_hubs
    from .app.segment import segment as run
    from .io.atomic import dumps_json

    _files_asked("segment", out, geojson=geojson, plot=plot)
    if method is not None:
        import warnings

        from .errors import InputError

        if options.get("segmentation") is not None:
            raise InputError("segment(): give segmentation alone (method is its former name)")
        warnings.warn("segment(method=) is now segmentation=", DeprecationWarning, stacklevel=3)
        options["segmentation"] = method
    with _one_call(force, out):
        if hubs is not None:
            read, refused = hubs_options(options)
            refuse_with_hubs(hubs, refused)
            cfg = planner_config(config, **read)
            tiling = segment_hubs(data, cfg, hubs, days=_text(dates), out=out, plot=plot)
            return dict(json.loads(dumps_json(tiling.doc())))
        cfg = planner_config(config, **options)
        res = run(data, cfg, days=_text(dates), out=out, geojson=geojson, plot=plot)
    return dict(json.loads(dumps_json(res.doc())))  # as the file reads back


@_checked("plan_window")
def plan_window(
    data: Any,
    depots: str | Path | dict[str, Any] | Depots,
    date: str | int | dt.date,
    window: int,
    *,
    out: str | Path | None = None,
    method: str = "marops",
    fleet: str | Path | None = None,
    delivered: str | Path | None = None,
    fmt: str = "parquet",
    geojson: bool = False,
    report: bool = False,
    force: bool = False,
    config: str | Path | None = None,
    **options: Any,
) -> DayResult:
    """``marops plan-window``: one window's stops and routes, and its solver and window
    objective (``metrics``). ``depots``: a depots file, or the depots ``segment()``
    returns. Its options (``drones``, ``alpha``, ``policy``, …) are those of the
    command."""
    from .app.options import planner_config, refuse_both
    from .app.plan_window import plan_window as run
    from .data.dates import parse_day
    from .errors import option

    _files_asked("plan_window", out, geojson=geojson, report=report)
    refuse_both(_given(options, fleet=fleet))
    cfg = planner_config(config, **options)
    with _one_call(force, out):
        res = run(
            data,
            cfg,
            parse_day(str(date), cfg.data.year, option("date")),
            int(window),
            depots=depots,  # a path, or depots in memory (app.inputs.given_depots)
            method=method,
            fleet=_path(fleet),
            delivered=_path(delivered),
            out=_path(out),
            fmt=fmt,
            geojson=geojson,
            report=report,
        )
    metrics = {"solver": res.solver, "objective": res.objective}
    return DayResult(res.stops, res.routes, metrics, _path(out))


@_checked("replay_day")
def replay_day(
    data: Any,
    date: str | int | dt.date,
    *,
    out: str | Path | None = None,
    method: str = "marops",
    depots: str | Path | dict[str, Any] | Depots | None = None,
    fleet: str | Path | None = None,
    fmt: str = "parquet",
    geojson: bool = False,
    plot: bool = False,
    report: bool = False,
    force: bool = False,
    hubs: str | Path | None = None,
    config: str | Path | None = None,
    **options: Any,
) -> DayResult:
    """``marops replay-day --date``: the day's stops, routes and metrics. ``depots``: a
    depots file, or the depots ``segment()`` returns (None: segmented from the other
    days). ``area="hubs"`` (or a ``hubs`` file) plans the whole city (docs/method.md
    §1.1): the result's tables hold every hub's rows (their ``hub`` column says
    which), ``metrics`` the city's ``metrics.json`` and ``city`` its coverage. Its
    options (``drones``, ``alpha``, ``segment``, …) are those of the command."""
    from .app.options import refuse_both
    from .app.replay import ReplayOptions, check_options, replay_config, replay_days
    from .data.dates import parse_day
    from .errors import option

    _files_asked("replay_day", out, geojson=geojson, plot=plot, report=report)
    refuse_both(_given(options, fleet=fleet, depots=depots))
    opts = ReplayOptions(method, fmt, plot, geojson, force, keep_tables=True, report=report)
    check_options(opts)
    cfg = replay_config(config, method=method, **options)
    day = parse_day(str(date), cfg.data.year, option("date"))
    with _one_call(force, out):
        res = replay_days(
            data,
            cfg,
            [day],
            options=opts,
            out=_path(out),
            several=False,
            depots=depots,
            fleet=_path(fleet),
            hubs=_path(hubs),
            protect={"config": _path(config)},
        )
    if res.city is not None:
        return _city_day(res, _path(out), fmt, cfg.data.tz)
    if not res.tables:  # the day was in ``out`` already, made with the same settings
        return _read_back(Path(out or "."), res.days[0], fmt, cfg.data.tz)
    tables = res.tables[0]
    return DayResult(tables.stops, tables.routes, res.days[0], _path(out))


def _city_day(res: Any, out: Path | None, fmt: str, tz: str) -> DayResult:
    """A city's day: every hub's tables one below the other (each row names its
    ``hub``; a hub kept from an earlier run into ``out`` read back from its folder), the
    city's metrics and coverage."""
    import pyarrow as pa

    replayed = {t.hub: t for t in res.tables}
    stops, routes = [], []
    for m in res.days:
        t = replayed.get(m["hub"])
        kept = Path(out or ".") / f"hub-{m['hub']}"
        day = t if t is not None else _read_back(kept, m, fmt, tz)
        stops.append(day.stops.replace_schema_metadata(None))
        routes.append(day.routes.replace_schema_metadata(None))
    metrics = {"city": res.city, "days": res.days, "total": res.total}
    return DayResult(
        pa.concat_tables(stops, promote_options="default"),
        pa.concat_tables(routes, promote_options="default"),
        metrics,
        out,
        res.city,
    )


def _read_back(folder: Path, metrics: dict[str, Any], fmt: str, tz: str) -> DayResult:
    """A day kept from an earlier run into ``folder``: its tables read from its files,
    as a replayed day's are: in seconds (Parquet keeps milliseconds), without the files'
    GeoParquet ``geometry`` column and ``geo`` metadata; from ``stops.json`` and
    ``routes.json`` with ``fmt="json"``, times in the data's zone ``tz``."""
    import pyarrow as pa

    from .config import MAX_DAY_ROUTES, MAX_DAY_STOPS
    from .data.arrow import parquet_rows, read_parquet
    from .data.jsonfile import first_line
    from .errors import InputError

    def read(name: str) -> pa.Table:
        if fmt == "json":
            return _json_table(folder / name.replace(".parquet", ".json"), tz)
        most = MAX_DAY_STOPS if name == "stops.parquet" else MAX_DAY_ROUTES
        rows = parquet_rows(folder / name)  # its footer: no row read yet
        if rows > most:
            raise InputError(
                f"a day's file edited since marops wrote it ({rows:,} rows, more than the "
                f"{most:,} a day's replay writes); pass force=True to replay the day",
                file=folder / name,
            )
        table = read_parquet(folder / name)
        if "geometry" in table.column_names:
            table = table.drop_columns(["geometry"])
        fields = [
            f.with_type(pa.timestamp("s", f.type.tz)) if pa.types.is_timestamp(f.type) else f
            for f in table.schema
        ]
        meta = {k: v for k, v in (table.schema.metadata or {}).items() if k != b"geo"}
        try:
            return table.cast(pa.schema(fields, metadata=meta))
        except pa.ArrowInvalid as exc:  # times marops writes in whole seconds: edited since
            raise InputError(
                f"a day's file edited since marops wrote it ({first_line(exc)}); pass "
                "force=True to replay the day",
                file=folder / name,
            ) from None

    return DayResult(read("stops.parquet"), read("routes.parquet"), metrics, folder)


def _json_table(path: Path, tz: str) -> Any:
    """A day's ``stops.json`` or ``routes.json`` as the table it was written from: its
    columns' types, ISO times and days read back, its ``meta`` as the table's."""
    import pyarrow as pa

    from .data.jsonfile import first_line
    from .errors import InputError
    from .io.routejson import read_route_json
    from .io.tables import routes_schema, stops_schema, with_meta

    key = path.stem  # "stops" or "routes"
    doc = read_route_json(path)
    rows = doc.get(key) if isinstance(doc, dict) else None
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise InputError(
            f"expected a list of rows under {key!r}: edited since marops wrote it; pass "
            "force=True to replay the day",
            file=path,
        )
    schema = stops_schema(tz) if key == "stops" else routes_schema(tz)
    parse = {
        f.name: dt.datetime.fromisoformat
        if pa.types.is_timestamp(f.type)
        else dt.date.fromisoformat
        for f in schema
        if pa.types.is_timestamp(f.type) or pa.types.is_date(f.type)
    }
    try:
        for row in rows:
            for name, read in parse.items():
                if isinstance(row.get(name), str):
                    row[name] = read(row[name])
        table = pa.Table.from_pylist(rows, schema=schema)
    except (ValueError, TypeError, pa.ArrowException) as exc:
        raise InputError(
            f"a day's file edited since marops wrote it ({first_line(exc)}); pass force=True "
            "to replay the day",
            file=path,
        ) from None
    return with_meta(table, doc.get("meta", {}))


@_checked("evaluate")
def evaluate(
    data: Any,
    *,
    out: str | Path | None = None,
    methods: str | list[str] | None = None,
    dates: str | list[str] | None = None,
    split: str | None = None,
    repeats: int = 1,
    drones: str | list[int] | None = None,
    alpha: str | list[float] | None = None,
    frontier: bool = False,
    coverage: str | list[float] | None = None,
    n_depots: str | list[int] | None = None,
    workers: int = 2,
    scheduler: str | None = None,
    hubs: str | Path | None = None,
    policy: str | Path | None = None,
    mappo_policy: str | Path | None = None,
    against: str | list[str] | None = None,
    plots: bool = True,
    report: bool = False,
    force: bool = False,
    config: str | Path | None = None,
    **options: Any,
) -> EvaluationResult:
    """``marops evaluate``: per-day results and their summary. Sweeps take "a,b,c"
    strings (``drones="4,8"``). The replays run on ``workers`` processes, which import
    the calling script as Python's multiprocessing does: in a script, call this under
    ``if __name__ == "__main__":`` (or pass ``workers=1``). Its options (``seed``,
    ``area``, …) are those of the command."""
    from .app.evaluate import evaluate as run
    from .app.evaluate import sweep_fields
    from .app.inputs import in_memory, read_data
    from .app.options import evaluate_config
    from .app.progress import SILENT
    from .evaluate.paired import comparison_warning

    _files_asked("evaluate", out, report=report)
    sweeps = (_text(alpha), _text(drones), _text(coverage), _text(n_depots))
    spec = evaluate_config(
        config,
        options,
        methods=_text(methods),
        dates=(_text(dates) or "") if dates is not None else None,
        split=split,
        hubs=hubs,
        policy=policy,
        mappo_policy=mappo_policy,
        **sweep_fields(*sweeps, frontier=frontier),
        repeats=repeats,
        workers=workers,
        scheduler=scheduler,
        against=_text(against),
        plots=plots,
        force=force,
        report=report,
    )
    source = read_data(data, spec.planner.data) if in_memory(data) else Path(data)
    with _one_call(force, out):
        res = run(source, spec, out=_path(out))
    if (few := comparison_warning(res.summary, res.paired)) is not None:
        SILENT.warning(few)  # as the command warns, at the caller's line
    return EvaluationResult(res.results, res.summary, res.folder, res.paired, res.frontier)


@_checked()
def report(
    folder: str | Path,
    *,
    depots: str | Path | dict[str, Any] | Depots | None = None,
    force: bool = False,
) -> list[Path]:
    """``marops report``: write ``report.html`` into an earlier run's output folder (and
    its day and hub folders; docs/report.md); the files written."""
    from .app.report import make_report
    from .io.ownership import replacing_foreign_files

    with replacing_foreign_files(force):
        return make_report(folder, depots=depots)
