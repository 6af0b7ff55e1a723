"""The values a report reads back from a run's files, checked as marops writes them
(docs/report.md): an edited file is one line naming the file and its row and column (a
table's: the header is row 1, as a spreadsheet shows it) or key (a JSON file's), never
an error of the page's making. Tables are checked a column at a time, not a cell."""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from ..data.arrow import is_text
from ..data.jsonfile import first_line
from ..errors import InputError, quoted

EDITED = "edited since marops wrote it"

Kind = Literal["int", "number", "text", "bool", "time", "date"]

_NUMBER = r"(?i)^\s*[-+]?((\d+\.?\d*|\.\d+)(e[-+]?\d+)?|inf|infinity|nan)\s*$"
"""A cell of text that is a number (pyarrow reads a column with any other cell as text)."""
_BOOLS = ("true", "false", "1", "0")
"""A cell of text that is true or false, as pyarrow reads a CSV's."""


@dataclass(frozen=True)
class Col:
    """What a column (or a key of each row) holds as marops writes it."""

    kind: Kind
    empty: bool | frozenset[str] = False
    """May a cell be empty (null): never, in any row, or in the stops of these kinds."""
    finite: bool = True
    """A number is finite (a CSV's ``nan`` reads as an empty cell)."""
    values: tuple[str, ...] = ()
    """Text: one of these (any, where none is given)."""

    def expected(self) -> str:
        """What a cell holds, as a message says it."""
        if self.values:
            return "one of " + ", ".join(repr(v) for v in self.values)
        return {
            "int": "a whole number",
            "number": "a finite number" if self.finite else "a number",
            "text": "text",
            "bool": "true or false",
            "time": "a time",
            "date": "a date (YYYY-MM-DD)",
        }[self.kind]


def cell_fits(value: Any, col: Col, kind: Any = None) -> bool:
    """A JSON file's ``value`` holds what ``col`` says (``kind``: the row's stop kind)."""
    if value is None:
        return col.empty is True or (not isinstance(col.empty, bool) and str(kind) in col.empty)
    if col.kind in ("int", "number"):
        if isinstance(value, bool) or not isinstance(value, int | float):
            return False
        if col.kind == "int":
            return isinstance(value, int)
        return not col.finite or math.isfinite(value)
    if col.kind == "bool":
        return isinstance(value, bool)
    if not isinstance(value, str):
        return False
    if col.kind == "text":
        return not col.values or value in col.values
    try:
        (dt.datetime if col.kind == "time" else dt.date).fromisoformat(value)
    except ValueError:
        return False
    return True


def check_cell(value: Any, col: Col, path: Path, key: str, kind: Any = None) -> None:
    """:func:`cell_fits`, else one line naming ``path`` and ``key``."""
    if not cell_fits(value, col, kind):
        got = "null" if value is None else quoted(value)
        expected = col.expected() + (
            " (ISO 8601: 2022-08-11T09:00:00+08:00)" if col.kind == "time" else ""
        )
        raise InputError(f"expected {expected}, got {got}: {EDITED}", file=path, column=key)


def require_columns(
    table: pa.Table, path: Path, names: Iterable[str], what: str, *, redo: str
) -> None:
    """Each of ``names`` a column of ``table`` (read from ``path``, ``what`` marops
    writes there); the first missing is one line naming it. ``redo``: how to write the
    file again."""
    for name in names:
        if name not in table.column_names:
            raise InputError(
                f"has no column {name!r}: not as marops writes {what} "
                f"(edited since, or of an older marops: {redo})",
                file=path,
                column=name,
            )


def check_table(
    table: pa.Table, path: Path, columns: Mapping[str, Col], what: str, *, redo: str
) -> None:
    """Each of ``columns`` in ``table`` (read from ``path``, ``what`` marops writes there:
    ``an evaluation's summary``) holding what it says; the first cell that does not is
    one line naming its row and column. ``redo``: how to write the file again."""
    require_columns(table, path, columns, what, redo=redo)
    kinds = table.column("kind") if "kind" in table.column_names else None
    for name, col in columns.items():
        column = table.column(name)
        i = _first_bad(column, col, kinds)
        if i is not None:
            cell = column[i]
            got = quoted(_py(cell)) if cell.is_valid else _EMPTY.get(path.suffix, _EMPTY[""])
            raise InputError(
                f"expected {col.expected()}, got {got}: {EDITED}", file=path, row=i + 2, column=name
            )


_EMPTY = {"": "an empty cell", ".csv": "an empty cell or nan"}
"""An empty cell as a message says it (a CSV reads ``nan`` as one)."""


def _py(cell: pa.Scalar) -> Any:
    try:
        return cell.as_py()
    except (OverflowError, ValueError):  # a time Python cannot hold
        return str(cell)


def _first_bad(column: pa.ChunkedArray, col: Col, kinds: pa.ChunkedArray | None) -> int | None:
    """The first row of ``column`` that does not hold what ``col`` says, or None: an
    empty cell where none may be, or a value of another kind."""
    null = _numpy(pc.is_null(column))
    bad = null.copy()
    if col.empty is True:
        bad[:] = False
    elif col.empty and kinds is not None:
        bad &= ~_numpy(pc.is_in(kinds, value_set=pa.array(sorted(col.empty))).fill_null(False))
    if not pa.types.is_null(column.type):  # else every cell empty: a column of no type
        bad |= ~null & _wrong(column, col)
    return _first(bad)


def _wrong(column: pa.ChunkedArray, col: Col) -> np.ndarray:
    """Which cells of ``column`` hold a value of another kind than ``col`` says (any of
    an empty cell)."""
    t = column.type
    if col.kind in ("int", "number"):
        values, number = _numbers(column)
        with np.errstate(invalid="ignore"):
            if col.kind == "int":
                return ~number | ~np.isfinite(values) | (values != np.floor(values))
            return ~number | (~np.isfinite(values) if col.finite else False)
    if col.kind == "text" and is_text(t) and col.values:
        return ~_numpy(pc.is_in(column, value_set=pa.array(col.values)).fill_null(True))
    if col.kind == "bool" and is_text(t):  # a column pyarrow could not read as true and false
        words = pc.utf8_lower(pc.utf8_trim_whitespace(column))
        return ~_numpy(pc.is_in(words, value_set=pa.array(_BOOLS)).fill_null(True))
    fits = {
        "text": is_text(t),
        "bool": pa.types.is_boolean(t),
        "time": pa.types.is_timestamp(t),
        "date": pa.types.is_date(t) or is_text(t),
    }
    return np.full(len(column), not fits.get(col.kind, True))


def _numbers(column: pa.ChunkedArray) -> tuple[np.ndarray, np.ndarray]:
    """(each cell as a float, NaN where empty or none; which cells are numbers)."""
    t = column.type
    if pa.types.is_integer(t) or pa.types.is_floating(t):
        values = _numpy(column.cast(pa.float64(), safe=False))
        return values, ~_numpy(pc.is_null(column))
    if is_text(t):
        number = pc.match_substring_regex(column, _NUMBER).fill_null(False)
        kept = pc.utf8_trim_whitespace(pc.if_else(number, column, pa.scalar(None, t)))
        return _numpy(kept.cast(pa.float64())), _numpy(number)
    n = len(column)
    return np.full(n, np.nan), np.zeros(n, dtype=bool)


def _numpy(column: pa.ChunkedArray | pa.Array) -> np.ndarray:
    if isinstance(column, pa.ChunkedArray):
        column = column.combine_chunks()
    if pa.types.is_boolean(column.type):
        return np.asarray(column.fill_null(False).to_numpy(zero_copy_only=False), dtype=bool)
    return np.asarray(column.to_numpy(zero_copy_only=False), dtype=np.float64)


def _first(mask: np.ndarray) -> int | None:
    idx = np.flatnonzero(mask)
    return int(idx[0]) if idx.size else None


def check_meta(
    meta: Mapping[str, Any],
    path: Path,
    keys: Mapping[str, type | tuple[type, ...]],
    at: str = "meta.",
) -> None:
    """The marops metadata ``meta`` of ``path`` holding a value of the type ``keys`` gives
    for each of them that it has (none is required: an older marops wrote fewer).
    ``at``: where ``meta`` is in a JSON file (its top level: ``""``)."""
    for key, kind in keys.items():
        value = meta.get(key)
        if value is None:
            continue
        number = kind in (int, float) or (isinstance(kind, tuple) and float in kind)
        if not isinstance(value, kind) or (number and isinstance(value, bool)):
            raise meta_error(path, key, _TYPE_WORDS.get(kind, "another type"), value, at)


_TYPE_WORDS: dict[Any, str] = {
    dict: "an object",
    list: "a list",
    str: "text",
    int: "a whole number",
    (int, float): "a number",
}


def meta_error(path: Path, key: str, expected: str, value: Any, at: str = "meta.") -> InputError:
    """The error of the marops metadata ``key`` of ``path``: the key named as a JSON
    file's (``meta.solver``; ``at``: where the metadata is in the file), in the message
    for a table's (its metadata is no column)."""
    got = f"got {quoted(value)}: {EDITED}"
    if path.suffix == ".json":
        return InputError(f"expected {expected}, {got}", file=path, column=f"{at}{key}")
    return InputError(f"its marops metadata {key!r}: expected {expected}, {got}", file=path)


@contextmanager
def reading(*paths: Path) -> Iterator[None]:
    """The last resort where a check missed an edit: what the page makes of ``paths``
    failing (a value of another type, a key gone) is one line naming the file (the
    folder, and the files by name, where the page reads several at once)."""
    try:
        yield
    except (TypeError, ValueError, KeyError, AttributeError, IndexError) as exc:
        if not paths:  # files not read from a folder: the report names the folder
            raise
        why = f"edited or not marops's ({first_line(exc)})"
        if len(paths) == 1:
            raise InputError(f"holds what marops cannot report on, {why}", file=paths[0]) from exc
        names = " and ".join(p.name for p in paths)
        raise InputError(
            f"its {names} hold what marops cannot report on, {why}", file=paths[0].parent
        ) from exc
