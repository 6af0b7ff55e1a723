"""Read and validate a LaDe-D delivery export, CSV or Parquet (docs/method.md §1).

:func:`read_lade` returns the kept rows as a :class:`LadeTable` and accounts for
every other row in its :class:`DropReport`. What is an error and what is dropped:

- errors (:class:`InputError`, exit 2, naming file, row and column): a file that
  is not CSV/Parquet, is empty or has no data rows; a missing required column; a
  non-empty time that does not parse (and is no missing-value marker); a ``ds``
  that is not a ``MMDD`` date; an empty ``order_id`` (or one of whitespace only) on a
  row with a time (a row of neither is empty: dropped as ``missing_time``); a
  ``weight_kg`` (when the column exists) that is empty, not a number or not positive.
- ``order_id`` is read as the text of the id: trimmed of whitespace, and an integral
  number written with a fraction of zeros (``601954.0``: a float column, or its
  text) as its digits (``601954``); duplicates, parcel weights and the outputs see
  this text.
- dropped and counted, before any check: ``malformed_row`` (a CSV line of another
  number of fields than the header: a last line cut short by an interrupted export,
  a stray separator; when they are most of the file's rows it is no LaDe layout, an
  error naming the first) and ``repeated_header`` (the header line again, where two
  exports were written one after the other).
- dropped and counted, in this order of precedence (a row counts once, under the
  first reason that applies): ``missing_time`` (accept or delivery time empty, or
  a marker exports write for a missing value: ``NULL``, ``\\N``, ``NaN``, ``None``,
  ``--``),
  ``bad_coordinates`` (lng/lat empty, not a number, NaN or out of range, or 0 where
  the column's other values lie more than a degree from 0: a mark of a missing value,
  where near the prime meridian or the equator it is a place; a
  non-numeric string is dropped rather than an error because real exports write
  placeholders such as ``null`` or ``--`` there), ``duplicate`` (same order_id,
  both times, lng and lat as an earlier row; the first is kept) and
  ``delivery_before_accept``. With ``cfg.strict`` the first such row in file
  order is an error instead.

Only the columns used are read (``REQUIRED_COLUMNS`` and ``ds``, ``aoi_id``,
``weight_kg``): the others may hold anything, bytes that are not UTF-8 included.

Row numbers are 1-based with the header as row 1, counting non-blank lines
(pyarrow skips blank lines) and the dropped malformed lines; for Parquet the first
data row is row 2 as well.
:func:`read_lade_table` reads the same columns from a pandas DataFrame or a pyarrow
Table in memory (the Python API's data), numbering its rows the same way.
"""

from __future__ import annotations

import csv
import datetime as dt
import errno
import hashlib
import io
import re
import stat
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from decimal import Decimal
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from ..errors import InputError, not_found, option, quoted, switch
from .arrow import is_text, native_file
from .dates import (
    TIME_BAD,
    TIME_EMPTY,
    TIME_OK,
    ds_dates,
    ds_other_day,
    instants,
    read_times,
    years_of,
)
from .digest import sha256_file
from .settings import DataSettings
from .table import DROP_REASONS, REQUIRED_COLUMNS, DropReport, LadeTable, SourceInfo

_OPTIONAL_COLUMNS = ("ds", "aoi_id", "weight_kg")
_NUMBER_COLUMNS = ("lng", "lat", "weight_kg")
# The column named when a row is dropped (in --strict errors), per reason.
_REASON_COLUMN = {
    "duplicate": "order_id",
    "delivery_before_accept": "delivery_time",
}
_BLOCK_BYTES = 16 << 20  # pyarrow CSV block: large blocks parse faster on few cores
MAX_EXPORT_ROWS = 20_000_000
"""The most rows one export may have (docs/method.md §1): a city's LaDe-D file has 1.5
million (Shanghai's), the whole release about 11 million; a Parquet file of more is
refused by its footer, before a row is read, where a few megabytes of repeated rows
would unpack to tens of gigabytes."""
MAX_EXPORT_BYTES = 4 << 30
"""The most bytes of text one CSV export may have, once decompressed (Shanghai's LaDe-D
file has 0.26 GB), and of column data a Parquet export's footer may give: a gzip that
unpacks to more is refused as its text is read, before it fills the memory."""


def _sniff(path: Path) -> tuple[str, str | None]:
    """('csv' | 'parquet', compression) from the file's first bytes, else its suffix."""
    try:
        st = path.stat()
        if stat.S_ISDIR(st.st_mode):
            raise InputError("is a folder, expected a LaDe CSV or Parquet file", file=path)
        if not stat.S_ISREG(st.st_mode):
            # A pipe would block the open until a writer came, and is read once only.
            raise InputError(
                "is not a regular file (a pipe or a device): the data is read more than "
                "once; give - to read it from standard input",
                file=path,
            )
        size = st.st_size
        with open(path, "rb") as f:
            head = f.read(4096)
    except OSError as exc:
        if isinstance(exc, FileNotFoundError) or exc.errno == errno.ELOOP:
            raise not_found(path) from exc
        raise InputError(f"cannot read the file ({exc.strerror})", file=path) from exc
    if size == 0:
        raise InputError("the file is empty", file=path)
    if head[:4] == b"PAR1":
        return "parquet", None
    suffixes = [s.lower() for s in path.suffixes]
    if suffixes[-1:] in ([".parquet"], [".pq"]):
        raise InputError("not a Parquet file (no PAR1 magic bytes)", file=path)
    if head[:2] == b"\x1f\x8b":
        return "csv", "gzip"
    _refuse_binary(head, path)
    at = 0
    while True:
        try:
            head[at:].decode("utf-8")
            break
        except UnicodeDecodeError as exc:
            at += exc.start
        # A cut multi-byte character at the end of the sample is fine; bytes before it are not.
        if at >= len(head) - 4:
            break
        error = _not_utf8(head, at, path)
        # Columns marops does not read are not read (pyarrow leaves them out): any bytes,
        # their names in the header too (no name it reads holds such a byte).
        if error.column is None or error.column in REQUIRED_COLUMNS + _OPTIONAL_COLUMNS:
            raise error
        at += 1
    return "csv", None


def _refuse_binary(head: bytes, path: Path) -> None:
    """Refuse a file whose first bytes are no UTF-8 text: wide text (UTF-16, UTF-32), a
    workbook or a ZIP archive, or any other binary file."""
    if (wide := _wide_text(head)) is not None:
        raise InputError(f"{wide} text, not UTF-8 (save the file as UTF-8)", file=path)
    if head[:4] == b"PK\x03\x04" or head[:8] == b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1":
        # A ZIP archive (an .xlsx workbook) or an OLE2 one (a legacy .xls).
        raise InputError(
            "not a CSV or Parquet file but a spreadsheet workbook or a ZIP archive: "
            "save the sheet as CSV (UTF-8), or unzip it",
            file=path,
        )
    if b"\x00" in head:
        raise InputError("not a CSV or Parquet file", file=path)


def _wide_text(head: bytes) -> str | None:
    """``UTF-16`` (``UTF-32``) when a file's first bytes are text in it (spreadsheets'
    "Unicode text"): a byte-order mark, or ASCII with a zero byte beside every
    character; else None."""
    if head[:4] in (b"\xff\xfe\x00\x00", b"\x00\x00\xfe\xff"):
        return "UTF-32"
    if head[:2] in (b"\xff\xfe", b"\xfe\xff"):
        return "UTF-16"
    sample = head[: min(64, len(head) // 2 * 2)]
    even, odd = sample[0::2], sample[1::2]
    if len(sample) >= 8 and ((not any(odd) and all(even)) or (not any(even) and all(odd))):
        return "UTF-16"
    return None


def _not_utf8(head: bytes, at: int, path: Path) -> InputError:
    """Where the first byte that is not UTF-8 lies in ``head`` (the file's first bytes):
    its row, its column (from the header line; in the header, the name holding it), its
    byte offset in the file."""
    lines = head[:at].split(b"\n")
    row = len(lines)
    names = next(csv.reader([head.split(b"\n", 1)[0].decode("utf-8", "replace")]), [])
    index = next(csv.reader([lines[-1].decode("utf-8", "replace")]), [""])
    k = max(len(index), 1) - 1  # the line up to the byte is empty: its first field
    column = names[k].strip() if 0 <= k < len(names) else None
    return InputError(
        f"not UTF-8 text: byte 0x{head[at]:02X} at byte offset {at} (save the file as UTF-8)",
        file=path,
        row=row,
        column=column,
    )


def _stream(path: Path, compression: str | None) -> pa.NativeFile:
    """The file as a pyarrow stream (:func:`native_file`: a name that is not UTF-8 opens)."""
    return pa.input_stream(native_file(path), compression=compression)


def _too_large(path: Path, what: str) -> InputError:
    return InputError(
        f"{what} more than the {MAX_EXPORT_BYTES / (1 << 30):g} GiB of text marops reads "
        "from one export (a city's LaDe-D file has 0.26 GB); split it by city or by date",
        file=path,
    )


def _too_many_rows(path: Path, rows: int) -> InputError:
    return InputError(
        f"holds {rows:,} rows, more than the {MAX_EXPORT_ROWS:,} marops reads from one "
        "export (a city's LaDe-D file has 1.5 million); split it by city or by date",
        file=path,
    )


class _Capped(io.RawIOBase):
    """A decompressed stream that refuses (:class:`InputError`) to give more than
    :data:`MAX_EXPORT_BYTES` (a small gzip may unpack to any size)."""

    def __init__(self, stream: pa.NativeFile, path: Path) -> None:
        super().__init__()
        self._stream, self._path, self._read = stream, path, 0

    def readable(self) -> bool:
        return True

    def read(self, size: int = -1) -> bytes:  # type: ignore[override]
        data = self._stream.read(None if size < 0 else size)
        self._read += len(data)
        if self._read > MAX_EXPORT_BYTES:
            raise _too_large(self._path, "its text unpacks to")
        return bytes(data)

    def close(self) -> None:
        self._stream.close()
        super().close()


def _csv_stream(path: Path, compression: str | None) -> io.RawIOBase | pa.NativeFile:
    """The CSV's text, at most :data:`MAX_EXPORT_BYTES` of it (else :class:`InputError`)."""
    if compression is None:
        size = path.stat().st_size
        if size > MAX_EXPORT_BYTES:
            raise _too_large(path, f"the file has {size:,} bytes,")
        return _stream(path, None)
    return _Capped(_stream(path, compression), path)


def _csv_header(path: Path, compression: str | None) -> list[str]:
    """Column names from the first line of a CSV file."""
    try:
        with _stream(path, compression) as f:
            head = f.read(1 << 20)
            # A header of tens of thousands of columns goes on past the first MiB: read
            # to its line end (a line past a parser block is refused as any row is).
            while b"\n" not in head and b"\r" not in head and len(head) < _BLOCK_BYTES:
                if not (more := f.read(1 << 20)):
                    break
                head += more
    except (OSError, pa.ArrowException) as exc:
        raise InputError(f"cannot read the file ({exc})", file=path) from exc
    text = head.decode("utf-8", errors="replace").removeprefix("\ufeff")
    if not text.strip():
        raise InputError("the file is empty", file=path)
    line = text.splitlines()[0]
    if not line.strip():
        raise InputError("expected column names on the first line, found a blank", file=path, row=1)
    try:
        names = [name.strip() for name in next(csv.reader([line]))]
    except csv.Error as exc:  # a field past csv's limit of 131,072 characters
        raise InputError(
            f"expected column names on the first line, found no CSV header ({exc})",
            file=path,
            row=1,
        ) from None
    if len(head) < _BLOCK_BYTES and "\n" not in text and "\r" not in text:
        # A header with no line end: pyarrow would fail on skipping it, with no hint why.
        _check_columns(names, path)
        raise InputError("the file has a header but no data rows", file=path, row=2)
    return names


_SEPARATORS = {";": "semicolons", "\t": "tabs", "|": "bars"}


def _separator_hint(names: list[str], name: str) -> str:
    """``; the header is separated by semicolons, ...`` when the header is one column
    that holds ``name`` between semicolons (tabs, bars): a CSV saved with another
    separator, which the error would otherwise call no LaDe file at all; and when the
    first line is a spreadsheet's ``sep=,`` above the header."""
    first = ",".join(names).strip()
    if first.lower().startswith("sep=") and len(first) <= 6:  # sep=, or sep=;
        return f"; the first line is {first!r}, a line for spreadsheets: delete it"
    if len(names) != 1:
        return ""
    for sep, word in _SEPARATORS.items():
        if name in (part.strip().strip('"') for part in names[0].split(sep)):
            return f"; the header is separated by {word}, not commas: save it as comma-separated"
    return ""


def _near_name_hint(names: list[str], name: str) -> str:
    """A hint naming the header's column that is ``name`` but for case, spaces or
    hyphens (``'Order_ID '``, ``order-id``); empty when there is none."""

    def plain(text: str) -> str:
        return "_".join(text.strip().strip('"').lower().replace("-", " ").split())

    near = next((n for n in names if n != name and plain(n) == name), None)
    if near is None:
        return ""
    return f"; the header has {near!r}: name it '{name}' (lower case, no spaces)"


def _check_columns(names: list[str], path: Path) -> list[str]:
    """The columns to load; raises for a missing required column or one named twice."""
    for name in REQUIRED_COLUMNS:
        if name not in names:
            hint = _near_name_hint(names, name) or _separator_hint(names, name)
            if name == "delivery_time" and "pickup_time" in names:
                hint = (
                    "; it has pickup_time: a LaDe-P pickup export, and marops plans "
                    "deliveries: give LaDe-D's delivery_<city>.csv"
                )
            raise InputError(
                f"missing required column '{name}': not a LaDe delivery file "
                f"(expected columns {', '.join(REQUIRED_COLUMNS)}){hint}",
                file=path,
                row=1,
                column=name,
            )
    wanted = REQUIRED_COLUMNS + _OPTIONAL_COLUMNS
    twice = next((n for n in wanted if names.count(n) > 1), None)
    if twice is not None:  # which of the two holds the data is anyone's guess
        raise InputError(
            f"column '{twice}' appears {names.count(twice)} times in the header",
            file=path,
            row=1,
            column=twice,
        )
    return [n for n in wanted if n in names]


Malformed = tuple[int, int, int]
"""A row the CSV parser left out: (its row number, its fields, the header's fields)."""


def _read_csv(path: Path, compression: str | None) -> tuple[pa.Table, list[Malformed]]:
    """The file's rows, and those left out for holding another number of fields than
    the header (a line cut short by an interrupted export, a stray separator): they
    are dropped as ``malformed_row``, unless they are most of the file's rows (another
    separator, say), which is an error naming the first."""
    names = _csv_header(path, compression)
    include = _check_columns(names, path)
    # Every column as text: times and ids keep their exact form, and a stray word in
    # a number column becomes a dropped row rather than a failed read.
    types = {n: pa.string() for n in include}
    convert = pacsv.ConvertOptions(
        column_types=types,
        include_columns=include,
        strings_can_be_null=True,
        null_values=[""],
    )

    def read(threads: bool, malformed: list[Malformed] | None) -> pa.Table:
        """The rows; those of another number of fields are left out and listed in
        ``malformed`` (with ``None`` for a number when the parser runs on threads),
        or an error when it is None."""
        opts = pacsv.ReadOptions(
            column_names=names, skip_rows=1, block_size=_BLOCK_BYTES, use_threads=threads
        )

        def skip(row: Any) -> str:  # pyarrow.csv.InvalidRow
            assert malformed is not None
            malformed.append((row.number, row.actual_columns, row.expected_columns))
            return "skip"

        parse = pacsv.ParseOptions(invalid_row_handler=None if malformed is None else skip)
        with _csv_stream(path, compression) as f:
            return pacsv.read_csv(
                f, read_options=opts, parse_options=parse, convert_options=convert
            )

    malformed: list[Malformed] = []
    try:
        try:
            table = read(threads=True, malformed=malformed)
            mostly = 2 * len(malformed) > table.num_rows + len(malformed)
            if malformed and not mostly and malformed[0][0] is None:
                # Only the single-threaded parser numbers the rows it leaves out.
                malformed = []
                table = read(threads=False, malformed=malformed)
            if mostly:  # not the rows of its header (another separator?): name the first
                read(threads=False, malformed=None)
        except pa.ArrowInvalid as exc:
            again = partial(read, threads=False, malformed=[])
            raise _csv_error(exc, path, names, compression, again) from exc
    except OSError as exc:  # a gzip stream damaged or cut short past its first megabyte
        why = " ".join(str(exc).split())
        what = "not a valid gzip file" if compression == "gzip" else "cannot read the file"
        raise InputError(f"{what} ({why})", file=path) from exc
    if table.num_rows == 0:
        raise InputError("the file has a header but no data rows", file=path, row=2)
    if table.num_rows > MAX_EXPORT_ROWS:  # short rows within the bytes: the same bound
        raise _too_many_rows(path, table.num_rows)
    return table, sorted(malformed)


def _csv_error(
    exc: Exception,
    path: Path,
    names: list[str],
    compression: str | None,
    retry: Callable[[], object],
) -> InputError:
    """An InputError for a CSV the parser refused, with the row when it can be found."""
    msg = str(exc)
    if "invalid UTF8" in msg:  # in a column read (the others are not read)
        try:  # the single-threaded parser names the row
            retry()
        except pa.ArrowInvalid as again:
            msg = str(again) if "invalid UTF8" in str(again) else msg
        m = re.search(r"column #(\d+)", msg)
        column = names[int(m.group(1))] if m and int(m.group(1)) < len(names) else None
        r = re.search(r"Row #(\d+)", msg)
        row = int(r.group(1)) if r else _first_non_utf8_line(path, compression)
        return InputError("not UTF-8 text", file=path, row=row, column=column)
    if "straddles two block boundaries" in msg:  # a row longer than a parser block
        row = _first_long_line(path, compression, _BLOCK_BYTES)
        mib = _BLOCK_BYTES >> 20
        return InputError(f"a row longer than {mib} MiB (a LaDe row is short)", file=path, row=row)
    # Only the single-threaded parser reports the row; the error path can afford it.
    try:
        retry()
    except pa.ArrowInvalid as again:
        msg = str(again)
    m = re.search(r"Row #(\d+): ", msg)
    row = int(m.group(1)) if m else None  # pyarrow counts the header as row 1 too
    msg = re.sub(r"Row #\d+: ", "", msg.removeprefix("CSV parse error: ")).strip()
    return InputError(f"not a valid CSV file: {msg}", file=path, row=row)


def _first_long_line(path: Path, compression: str | None, limit: int) -> int | None:
    """The number of the first line of more than ``limit`` bytes, read a block at a time
    (such a line is never held whole)."""
    number, length = 1, 0
    with _stream(path, compression) as f:
        while block := f.read(1 << 20):
            *ended, rest = block.split(b"\n")
            for part in ended:
                if length + len(part) > limit:
                    return number
                number, length = number + 1, 0
            length += len(rest)  # the line goes on into the next block
            if length > limit:
                return number
    return None


def _first_non_utf8_line(path: Path, compression: str | None) -> int | None:
    with _stream(path, compression) as f:
        for number, line in enumerate(io.BufferedReader(f), start=1):  # type: ignore[arg-type]
            try:
                line.decode("utf-8")
            except UnicodeDecodeError:
                return number
    return None


def _cut_column(path: Path, compression: str | None) -> str | None:
    """The header's last column when the CSV's text ends without a line end (an
    interrupted export: its last line may be cut short inside that field, keeping the
    header's number of fields), else None."""
    if compression is None:
        with native_file(path) as f:
            f.seek(max(f.size() - 1, 0))
            last = f.read(1)
    else:
        last = b""
        with _stream(path, compression) as f:
            while block := f.read(1 << 20):
                last = block[-1:]
    return None if last in (b"\n", b"\r") else _csv_header(path, compression)[-1]


def _read_parquet(path: Path) -> pa.Table:
    try:
        with pq.ParquetFile(_stream(path, None)) as pf:  # closed on every way out
            include = _check_columns(list(pf.schema_arrow.names), path)
            table = _read_parquet_capped(pf, path, include)
    except (pa.ArrowException, OSError, UnicodeDecodeError) as exc:
        # A damaged file raises OSError (a thrift or compression error) or, where a
        # name is not UTF-8, UnicodeDecodeError, as often as ArrowException.
        why = " ".join(str(exc).split())  # pyarrow's messages may end in a newline
        raise InputError(f"not a valid Parquet file ({why})", file=path) from exc
    if table.num_rows == 0:
        raise InputError("the file has no data rows", file=path, row=2)
    return table


def _read_parquet_capped(pf: pq.ParquetFile, path: Path, include: list[str]) -> pa.Table:
    """The columns ``include`` of a Parquet export: refused when its footer gives more
    than :data:`MAX_EXPORT_ROWS` rows, before a row is read, or once the columns read
    pass :data:`MAX_EXPORT_BYTES` (read a batch at a time: a dictionary-encoded column
    of a few kilobytes may unpack to gigabytes, which no footer tells)."""
    if pf.metadata.num_rows > MAX_EXPORT_ROWS:
        raise _too_many_rows(path, pf.metadata.num_rows)
    batches, size = [], 0
    for batch in pf.iter_batches(batch_size=1 << 16, columns=include):
        size += batch.nbytes
        if size > MAX_EXPORT_BYTES:
            raise _too_large(path, "its columns unpack to")
        batches.append(batch)
    if not batches:  # no rows: the table of its schema
        return pf.read(columns=include)
    return pa.Table.from_batches(batches)


def _numbers(column: pa.ChunkedArray) -> np.ndarray:
    """A column of numbers or numeric text -> float64, NaN where empty or not a number."""
    arr = column.combine_chunks()
    if pa.types.is_decimal(arr.type):  # read by its digits, as a CSV's: Arrow's own cast
        arr = arr.cast(pa.string())  # to float64 may miss the nearest double by one ulp
    if not is_text(arr.type):
        # Unchecked: an integer beyond 2**53 (no coordinate) rounds, then reads as bad.
        return arr.cast(pa.float64(), safe=False).to_numpy(zero_copy_only=False)
    try:  # fast path: a clean column casts at once
        values = arr.cast(pa.float64())
    except pa.ArrowInvalid:
        text = pc.utf8_trim_whitespace(arr)
        num = r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$"
        ok = pc.fill_null(pc.match_substring_regex(text, num), False)
        values = pc.if_else(ok, text, pa.scalar(None, pa.string())).cast(pa.float64())
    return values.to_numpy(zero_copy_only=False)


def _check_column_types(table: pa.Table, path: Path) -> pa.Table:
    """``table`` with each column checked for what its cells can be: numbers or text in
    ``lng``, ``lat`` and ``weight_kg`` (a Parquet file's booleans or dates there would
    otherwise read as 0/1 or fail late), and text, a number or a time in the others (a
    list or a struct is no id or time). Binary columns (Parquet strings some writers
    leave unannotated) become text, which must be UTF-8; Arrow's view layouts of text and
    binary (polars' ``to_arrow()`` gives them) and dictionary-encoded (categorical)
    columns are read as the plain ones."""
    for k, name in enumerate(table.column_names):
        t = table.schema.field(name).type
        if pa.types.is_dictionary(t):
            # A categorical column (pandas' category, a writer's dictionary encoding) is
            # read as its values, a plain column's cells: its text cells in a column of
            # numbers are then bad rows as theirs are, not an Arrow error.
            t = t.value_type
            cells = [chunk.dictionary_decode() for chunk in table[name].chunks]
            table = table.set_column(k, name, pa.chunked_array(cells, type=t))
        if pa.types.is_string_view(t) or pa.types.is_binary_view(t):
            t = pa.string() if pa.types.is_string_view(t) else pa.binary()
            table = table.set_column(k, name, table[name].cast(t))
        binary = pa.types.is_binary(t) or pa.types.is_large_binary(t)
        if binary:  # text, numbers in lng and lat included, once it is UTF-8
            table = table.set_column(k, name, _utf8(table[name], path, name))
            t = pa.string()
        numeric = (
            pa.types.is_integer(t)
            or pa.types.is_floating(t)
            or pa.types.is_decimal(t)
            or is_text(t)
            or pa.types.is_null(t)
        )
        if name in ("lng", "lat") and pa.types.is_float16(t):
            raise InputError(
                "expected coordinates, got a column of float16, whose numbers are kilometres "
                "apart at these degrees (0.0625 from 64 to 128); give float32 or float64",
                file=path,
                column=name,
            )
        if name in ("lng", "lat") and pa.types.is_integer(t):
            raise InputError(
                f"expected coordinates in decimal degrees, got a column of whole numbers ({t}): "
                "whole degrees are about 100 km apart, so every order would share a few points",
                file=path,
                column=name,
            )
        if name in _NUMBER_COLUMNS and not numeric:
            raise InputError(
                f"expected a column of numbers, got a column of type {t}", file=path, column=name
            )
        if not (numeric or pa.types.is_timestamp(t) or pa.types.is_date(t)):
            raise InputError(
                f"expected a column of text, numbers or times, got a column of type {t}",
                file=path,
                column=name,
            )
        if not binary and is_text(t):
            _check_utf8(table[name], path, name)
    return table


def _check_utf8(column: pa.ChunkedArray, path: Path, name: str) -> None:
    """A text column read from Parquet is not checked for UTF-8 by pyarrow: the first
    cell that is not UTF-8 is an error."""
    try:
        column.validate(full=True)
    except pa.ArrowInvalid:
        _utf8(column.cast(pa.large_binary()), path, name)


def _utf8(column: pa.ChunkedArray, path: Path, name: str) -> pa.ChunkedArray:
    """A binary column as text; the first cell that is not UTF-8 is an error."""
    try:
        return column.cast(pa.string())
    except pa.ArrowInvalid:
        for i, cell in enumerate(column.to_pylist()):  # the error path can afford a loop
            try:
                (cell or b"").decode("utf-8")
            except UnicodeDecodeError:
                raise InputError("not UTF-8 text", file=path, row=i + 2, column=name) from None
        raise


def _order_ids(column: pa.ChunkedArray) -> pa.ChunkedArray:
    """``order_id`` as text that names an order however the export wrote it: trimmed of
    whitespace, and an integral number written with a fraction of zeros (``601954.0``,
    as a float column or its text, which pandas writes for ids in a column with gaps)
    as the integer's digits. An id is hashed into its parcel weight, deduplicated and
    written to the outputs by this text, so ``' 601954 '`` and ``601954.0`` are order
    601954 there. NaN in a float column is no id (an empty cell); other ids keep their
    text, digits or not."""
    arr = column.combine_chunks()
    if pa.types.is_floating(arr.type):
        f = arr.cast(pa.float64()).fill_null(np.nan).to_numpy(zero_copy_only=False)
        with np.errstate(invalid="ignore"):
            whole = np.isfinite(f) & (f == np.floor(f)) & (np.abs(f) < 2.0**63)
        digits = pa.array(np.where(whole, f, 0).astype(np.int64)).cast(pa.string())
        text = pc.if_else(pa.array(whole), digits, arr.cast(pa.string()))
        return pa.chunked_array([pc.if_else(pa.array(np.isnan(f)), None, text)])
    text = arr if is_text(arr.type) else arr.cast(pa.string())
    text = pc.utf8_trim_whitespace(text)
    if pc.any(pc.match_substring(text, ".0")).as_py():  # a clean column has no fraction
        text = pc.replace_substring_regex(text, r"^(\d+)\.0+$", r"\1")
    return pa.chunked_array([text])


def _strings(column: pa.ChunkedArray) -> np.ndarray:
    """A column as an object array of str (ints in Parquet files become their digits)."""
    if not is_text(column.type):
        column = column.cast(pa.string())
    return column.fill_null("").to_numpy(zero_copy_only=False)


def _first(mask: np.ndarray) -> int | None:
    idx = np.flatnonzero(mask)
    return int(idx[0]) if idx.size else None


def _shown(column: pa.ChunkedArray, i: int) -> str:
    """Cell ``i`` as it reads in a message (its Python repr); a time or date Python
    cannot hold (beyond the year 9999) as its stored count and type."""
    cell = column[i]
    try:
        return repr(cell.as_py())
    except (OverflowError, ValueError):
        return f"{getattr(cell, 'value', cell)} ({cell.type}), outside the years 1-9999"


def _check_errors(
    table: pa.Table, path: Path, cfg: DataSettings, rows: np.ndarray
) -> dict[str, np.ndarray]:
    """Parse times, ds and weights; raise at the first cell that is an error, not a drop
    (naming its file row, ``rows``)."""
    out: dict[str, np.ndarray] = {}
    bad: list[tuple[int, str, str]] = []  # (index, column, message)
    for name in ("accept_time", "delivery_time"):
        times = read_times(table[name], cfg.year, cfg.tz)
        secs, status = times.secs, times.status
        out[name], out[name + "_status"] = secs, status
        out[name + "_utc"] = np.where(times.zoned, secs - times.offset, secs)
        out[name + "_zoned"] = times.zoned
        if (i := _first(status == TIME_BAD)) is not None:
            value = _shown(table[name], i)
            msg = f"expected a time MM-DD HH:MM:SS or YYYY-MM-DD HH:MM:SS, got {value}"
            if re.fullmatch(r"'\s*02-29[ T][\d:.]+\s*'", value):  # the form is right
                year = option("year")
                msg += f": February 29 is no day of {cfg.year}, the year of MM-DD times ({year})"
            bad.append((i, name, msg))
    # A ds without its year is a day of its delivery time's year (a full time's own,
    # 2024 for 229 beside 2024-02-29; --year where the time is MM-DD or no time).
    ds_year = np.where(
        out["delivery_time_status"] == TIME_OK, years_of(out["delivery_time"]), cfg.year
    )
    # An empty ds is harmless (the day comes from delivery_time); a malformed one is not.
    if "ds" in table.column_names:
        valid, out["ds"] = ds_dates(table["ds"], ds_year)
        ds_bad = ~valid & ~pc.equal(
            pc.utf8_length(pc.utf8_trim_whitespace(table["ds"].cast(pa.string()))), 0
        ).fill_null(True).to_numpy(zero_copy_only=False)
        if (i := _first(ds_bad)) is not None:
            value = _shown(table["ds"], i)
            bad.append((i, "ds", f"expected a date MMDD in {ds_year[i]}, got {value}"))
    oid = table["order_id"]
    empty_id = pc.fill_null(pc.equal(pc.utf8_length(oid.cast(pa.string())), 0), True)
    empty_id = empty_id.to_numpy(zero_copy_only=False)
    # No id and no times is an empty row, no order (a spreadsheet saves a row it
    # formatted as ,,,,): dropped as missing_time, as a blank line is skipped.
    empty_row = empty_id & (out["accept_time_status"] == TIME_EMPTY)
    empty_row &= out["delivery_time_status"] == TIME_EMPTY
    if (i := _first(empty_id & ~empty_row)) is not None:
        bad.append((i, "order_id", "expected an order id, got an empty cell"))
    if "weight_kg" in table.column_names:
        w = _numbers(table["weight_kg"])
        if (i := _first(~((w > 0) & np.isfinite(w)) & ~empty_row)) is not None:
            value = table["weight_kg"][i].as_py()
            empty = value is None or (isinstance(value, str) and not value.strip())
            shown = "an empty cell" if empty else _shown(table["weight_kg"], i)
            bad.append((i, "weight_kg", f"expected a positive weight in kg, got {shown}"))
        out["weight_kg"] = w
    if bad:
        i, column, message = min(bad)
        raise InputError(message, file=path, row=int(rows[i]), column=column)
    return out


ZERO_MARK_DEG = 1.0
"""A coordinate of 0 marks a missing value where the file's other values of that column
lie (their median) more than this many degrees from 0, as in LaDe's exports; nearer, by
the prime meridian or the equator (London, Quito), 0 is a place: an export rounded to 2
decimals has a strip of its orders there."""


def _good(values: np.ndarray, bound: float) -> np.ndarray:
    """The values that are coordinates within ``bound``: not NaN, and not 0 where 0 marks
    a missing value in this column (:data:`ZERO_MARK_DEG`)."""
    with np.errstate(invalid="ignore"):  # NaN compares False: dropped, as wanted
        inside = np.abs(values) <= bound
        placed = inside & (values != 0)
    others = values[placed]
    if others.size and abs(float(np.median(others))) <= ZERO_MARK_DEG:
        return inside
    return placed


def _good_lng(lng: np.ndarray) -> np.ndarray:
    return _good(lng, 180)


def _good_lat(lat: np.ndarray) -> np.ndarray:
    return _good(lat, 90)


def _code(reason: str) -> int:
    """The code of a drop reason in a code per row (:func:`_drop_reasons`): 0 is kept."""
    return DROP_REASONS.index(reason) + 1


def _swapped(code: np.ndarray, lng: np.ndarray, lat: np.ndarray) -> int:
    """How many rows dropped for bad coordinates would be good with lng and lat swapped
    (a latitude beyond ±90 whose longitude is one): the columns may be swapped."""
    bad = code == _code("bad_coordinates")
    if not bad.any():  # the common file: no median of a column to take
        return 0
    return int((bad & _good_lng(lat) & _good_lat(lng)).sum())


def _decimal_commas(code: np.ndarray, table: pa.Table) -> int:
    """How many rows dropped for bad coordinates have lng or lat written with a decimal
    comma (``"121,47"``, as a spreadsheet in a locale that writes numbers so saves them)."""
    bad = np.flatnonzero(code == _code("bad_coordinates"))
    if not bad.size:  # the common file: no text to match
        return 0
    comma = np.zeros(bad.size, dtype=bool)
    for name in ("lng", "lat"):
        cells = table[name].take(pa.array(bad))
        if is_text(cells.type):
            found = pc.match_substring_regex(cells, r"^\s*[-+]?\d+,\d+\s*$")
            comma |= pc.fill_null(found, False).to_numpy(zero_copy_only=False)
    return int(comma.sum())


def _over_new_year(code: np.ndarray, parsed: dict[str, np.ndarray]) -> int:
    """How many rows dropped as delivered before accepted were accepted in December and
    delivered in January of one year: ``MM-DD`` times of an export over the new year,
    which take one year (``--year``)."""
    late = code == _code("delivery_before_accept")
    if not late.any():  # the common file: no months to take
        return 0
    months = [
        (parsed[name][late] // 86_400).astype("datetime64[D]").astype("datetime64[M]")
        for name in ("accept_time", "delivery_time")
    ]
    accept, delivery = (m.astype(np.int64) for m in months)  # months since 1970-01
    return int(((accept % 12 == 11) & (delivery == accept - 11)).sum())


def _repeated(*columns: np.ndarray) -> np.ndarray:
    """Mask of rows whose values in ``columns`` (64-bit each) may repeat another row's.

    A multiplicative hash of the numeric keys, then one sort: every true repeat is
    caught, plus the rare collision, which the exact grouping afterwards sorts out.
    Grouping all 1.5 M rows by their string ids instead costs ~0.5 s and ~300 MB.
    """
    h = np.zeros(columns[0].shape[0], dtype=np.uint64)
    for col in columns:
        h = (h ^ np.ascontiguousarray(col).view(np.uint64)) * np.uint64(0x9E3779B97F4A7C15)
    _, inverse, counts = np.unique(h, return_inverse=True, return_counts=True)
    return counts[inverse] > 1


def _drop_reasons(
    table: pa.Table, parsed: dict[str, np.ndarray]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(reason code per row: 0 kept, k means DROP_REASONS[k-1]; lng; lat)."""
    n = table.num_rows
    code = np.zeros(n, dtype=np.int8)

    def mark(mask: np.ndarray, reason: str) -> None:
        code[(code == 0) & mask] = _code(reason)

    a_st, d_st = parsed["accept_time_status"], parsed["delivery_time_status"]
    mark((a_st == TIME_EMPTY) | (d_st == TIME_EMPTY), "missing_time")
    lng, lat = _numbers(table["lng"]), _numbers(table["lat"])
    mark(~(_good_lng(lng) & _good_lat(lat)), "bad_coordinates")
    accept, delivery = parsed["accept_time"], parsed["delivery_time"]
    live = np.flatnonzero(code == 0)
    live = live[_repeated(accept[live], delivery[live], lng[live], lat[live])]
    oid = table["order_id"].take(live)  # text (_order_ids)
    keys = pa.table(
        {"o": oid, "a": accept[live], "d": delivery[live], "x": lng[live], "y": lat[live]}
    ).append_column("i", pa.array(live))
    # The first occurrence of each key has the lowest row index.
    first = keys.group_by(["o", "a", "d", "x", "y"]).aggregate([("i", "min")])
    is_dup = np.zeros(n, dtype=bool)
    is_dup[live] = True
    is_dup[first["i_min"].to_numpy()] = False
    mark(is_dup, "duplicate")
    # In absolute time where both carry their zone: 01:10 GMT is 20 minutes after 01:50
    # BST, the hour the clocks go back; else as the wall clock reads.
    zoned = parsed["accept_time_zoned"] & parsed["delivery_time_zoned"]
    a_utc, d_utc = parsed["accept_time_utc"], parsed["delivery_time_utc"]
    mark(np.where(zoned, d_utc < a_utc, delivery < accept), "delivery_before_accept")
    return code, lng, lat


def _strict_error(
    code: np.ndarray,
    parsed: dict[str, np.ndarray],
    lng: np.ndarray,
    rows: np.ndarray,
    set_aside: list[tuple[int, str, str]],
    path: Path,
) -> InputError:
    """The error of the first row in the file that would be dropped: of the rows of
    ``code`` (their file rows ``rows``) and those set aside before, as (row, reason,
    what it held)."""
    first: list[tuple[int, str, str | None]] = [
        (r, f"{why}: {held}", None) for r, why, held in set_aside
    ]
    if code.any():
        i = int(np.flatnonzero(code)[0])
        reason = DROP_REASONS[code[i] - 1]
        if reason == "missing_time":
            status = parsed["accept_time_status"][i]
            name = "accept_time" if status == TIME_EMPTY else "delivery_time"
        elif reason == "bad_coordinates":
            name = "lat" if _good_lng(lng)[i] else "lng"
        else:
            name = _REASON_COLUMN[reason]
        first.append((int(rows[i]), reason, name))
    row, why, column = min(first, key=lambda f: f[0])
    return InputError(
        f"row would be dropped ({why}) and {switch('strict')} is set",
        file=path,
        row=row,
        column=column,
    )


def _file_rows(n: int, left_out: list[int]) -> np.ndarray:
    """The file's row number (the first data row is 2) of each of the ``n`` rows read,
    where the parser left out the rows numbered ``left_out``."""
    rows = np.arange(2, n + 2 + len(left_out), dtype=np.int64)
    if left_out:
        rows = rows[~np.isin(rows, left_out)]
    return rows[:n]


def _repeated_header(table: pa.Table) -> np.ndarray:
    """Mask of the rows that are the header line again (two exports written one after
    the other): each column read holds its own name (trimmed, a byte-order mark too)."""
    oid = table["order_id"]
    names = pa.array(["order_id", "\ufefforder_id"])
    maybe = np.flatnonzero(
        pc.is_in(oid, value_set=names).fill_null(False).to_numpy(zero_copy_only=False)
    )
    header = np.zeros(table.num_rows, dtype=bool)
    if maybe.size:
        cells = table.take(pa.array(maybe)).to_pylist()
        header[maybe] = [
            all(str(v).strip().lstrip("\ufeff").strip() == k for k, v in cell.items())
            for cell in cells
        ]
    return header


def read_lade(path: str | Path, cfg: DataSettings) -> LadeTable:
    """Read a LaDe-D delivery export (CSV, CSV.gz or Parquet) into a :class:`LadeTable`.

    The format is told by the file's magic bytes (Parquet ``PAR1``, gzip), else
    it is read as CSV. See the module docstring for what is dropped and what is
    an error. Raises :class:`InputError` for bad input.
    """
    path = Path(path)
    kind, compression = _sniff(path)
    # Hashing the file overlaps the parse: both release the GIL on large buffers.
    with ThreadPoolExecutor(max_workers=1) as pool:
        digest = pool.submit(sha256_file, path)
        malformed: list[Malformed] = []
        if kind == "parquet":
            table = _read_parquet(path)
        else:
            table, malformed = _read_csv(path, compression)
        # mimalloc keeps freed parse buffers; returning them cuts the peak by ~200 MB.
        pa.default_memory_pool().release_unused()

        def source() -> SourceInfo:
            return SourceInfo(
                path=str(path), name=path.name, size=path.stat().st_size, sha256=digest.result()
            )

        cut = None if kind == "parquet" else partial(_cut_column, path, compression)
        return _lade_table(table, str(path), cfg, source, malformed, cut)


IN_MEMORY = ("DataFrame", "Table")
"""The names an in-memory table goes by in messages and metadata (pandas, pyarrow)."""


def read_lade_table(data: object, cfg: DataSettings) -> LadeTable:
    """Read LaDe-D rows held in memory, a pandas ``DataFrame`` or a ``pyarrow.Table``
    with the export's columns, exactly as :func:`read_lade` reads a file: the same
    checks, drops and errors, which name ``DataFrame`` (or ``Table``) where they would
    name the file. Its identity (``input`` in the metadata) is the SHA-256 of its
    columns in Arrow's stream format. Rows are numbered as in a file: the first row
    is row 2; an error in a DataFrame's row names its index label too."""
    if isinstance(data, pa.Table):
        where, table = IN_MEMORY[1], data
    elif type(data).__name__ == "DataFrame" and hasattr(data, "iloc"):  # pandas
        where = IN_MEMORY[0]
        table = _frame_table(data, where)
    else:
        kind = type(data)
        name = (
            kind.__name__
            if kind.__module__ == "builtins"
            else f"{kind.__module__}.{kind.__qualname__}"
        )
        raise InputError(
            f"expected a LaDe file path, a pandas DataFrame or a pyarrow Table, got {name}"
        )
    include = _check_columns([str(n) for n in table.column_names], Path(where))
    table = table.select(include)
    if table.num_rows == 0:
        raise InputError(f"the {where} has no data rows", file=where, row=2)
    sink = pa.BufferOutputStream()
    with pa.ipc.new_stream(sink, table.schema) as writer:
        writer.write_table(table)
    buf = sink.getvalue()
    sha = hashlib.sha256(memoryview(buf)).hexdigest()

    def source() -> SourceInfo:
        return SourceInfo(path=where, name=where, size=buf.size, sha256=sha)

    try:
        return _lade_table(table, where, cfg, source)
    except InputError as exc:  # a frame's row is found by its index label: say it too
        index = getattr(data, "index", None) if where == IN_MEMORY[0] else None
        if type(exc) is not InputError or index is None or exc.row is None:
            raise
        if not 2 <= exc.row < len(index) + 2:
            raise
        label = index[exc.row - 2]
        shown = repr(label) if isinstance(label, str) else str(label)
        message = f"{exc.message} (the frame's index {shown})"
        raise InputError(message, file=exc.file, row=exc.row, column=exc.column) from None


def _frame_table(frame: Any, where: str) -> pa.Table:
    """The LaDe columns of a pandas DataFrame as a table: the other columns are not
    read (as a file's are not), and a column of mixed cells (numbers and words, as
    frames joined together hold) is read as its text, as a file's cells are."""
    levels = getattr(frame.columns, "nlevels", 1)
    if levels > 1:
        raise InputError(
            f"the frame's column names have {levels} levels (a MultiIndex); give one level, "
            "e.g. frame.droplevel(1, axis=1)",
            file=where,
            row=1,
        )
    names = [str(n) for n in frame.columns]
    in_index = [str(n) for n in getattr(frame.index, "names", []) if n is not None]
    for name in REQUIRED_COLUMNS:  # set_index("order_id") moves a column out of the rows
        if name not in names and name in in_index:
            raise InputError(
                f"missing required column '{name}': it is the frame's index; pass "
                "frame.reset_index() to read it as a column",
                file=where,
                row=1,
                column=name,
            )
    include = _check_columns(names, Path(where))
    columns = {}
    for name in include:
        col = frame.iloc[:, names.index(name)]
        if hasattr(col, "sparse") and str(col.dtype).startswith("Sparse"):
            col = col.sparse.to_dense()  # a sparse column holds the same cells
        if col.dtype == object and _of_several_kinds(col):
            columns[name] = _cells_text(col, frame.index, where, name)
            continue
        try:
            columns[name] = pa.Array.from_pandas(col)
        except (pa.ArrowException, TypeError, ValueError) as exc:
            if col.dtype != object:
                msg = f"expected a column of text, numbers or times, got a column of {col.dtype}"
                raise InputError(msg, file=where, column=name) from exc
            text = col.astype(str).to_numpy(dtype=object)
            text[col.isna().to_numpy(dtype=bool)] = None
            columns[name] = pa.array(text, type=pa.string())
    return pa.table(columns)


def _of_several_kinds(col: Any) -> bool:
    """Whether a column of Python objects holds cells of several kinds (numbers and
    words, as frames joined together hold) or ones that are no cell of a file (lists,
    dicts). Arrow would make one type of them where it can: the integers beside a
    ``datetime`` would be times of 1970, every id wrong."""
    from pandas.api.types import infer_dtype

    return infer_dtype(col, skipna=True) in ("mixed", "mixed-integer")


_CELLS = (str, bytes, int, float, Decimal, dt.date, np.generic)
"""What a cell of a frame's column may be: what a file's cell reads as (text, a number,
a time), numpy's scalars included."""


def _cells_text(col: Any, index: Any, where: str, name: str) -> pa.Array:
    """A frame's column of cells of several kinds as their text, as a file's cells are
    (bytes as UTF-8); a cell that is no text, number or time (a list, a dict) is an
    error naming its row, which would otherwise be an id ``[1]``."""
    empty = col.isna().to_numpy(dtype=bool)
    text: list[str | None] = []
    for i, cell in enumerate(col.to_numpy(dtype=object)):
        if empty[i]:
            text.append(None)
            continue
        why = ""
        if not isinstance(cell, _CELLS) or isinstance(cell, np.ndarray):
            why = f"expected text, a number or a time, got {quoted(cell)} ({type(cell).__name__})"
        elif isinstance(cell, bytes):
            try:
                cell = cell.decode("utf-8")
            except UnicodeDecodeError:
                why = "not UTF-8 text"
        if why:
            label = index[i]
            shown = repr(label) if isinstance(label, str) else str(label)
            raise InputError(
                f"{why} (the frame's index {shown})", file=where, row=i + 2, column=name
            )
        text.append(str(cell))
    return pa.array(text, type=pa.string())


def _lade_table(
    table: pa.Table,
    where: str,
    cfg: DataSettings,
    source: Callable[[], SourceInfo],
    malformed: list[Malformed] | None = None,
    cut: Callable[[], str | None] | None = None,
) -> LadeTable:
    """The kept rows of ``table`` (all columns read) and its drop report; ``where``
    names it in errors, ``source()`` is its identity; ``malformed`` are the rows the
    CSV parser left out (:func:`_read_csv`), sorted; ``cut()`` names the column the
    CSV's last line may be cut short in (:func:`_cut_column`)."""
    path = Path(where)
    malformed = malformed or []
    table = _check_column_types(table, path)
    k = table.schema.get_field_index("order_id")
    table = table.set_column(k, "order_id", _order_ids(table["order_id"]))
    rows = _file_rows(table.num_rows, [m[0] for m in malformed])
    set_aside = [
        (row, "malformed_row", f"{got} fields, the header has {want}")
        for row, got, want in malformed
    ]
    header = _repeated_header(table)
    if header.any():  # the header's names are no times: set aside before the checks
        set_aside += [(int(r), "repeated_header", "the header line again") for r in rows[header]]
        table, rows = table.filter(pa.array(~header)), rows[~header]
    try:
        parsed = _check_errors(table, path, cfg, rows)
    except InputError as exc:
        # An export interrupted inside its last line's last field (LaDe's ds: 8 of 803)
        # leaves it the header's fields: that cell, not reading, is the cut.
        last = int(rows[-1])
        if exc.row != last or table.num_rows < 2 or cut is None or exc.column != cut():
            raise
        set_aside.append((last, "malformed_row", "cut short where the file ends"))
        table, rows = table.slice(0, table.num_rows - 1), rows[:-1]
        parsed = _check_errors(table, path, cfg, rows)
    code, lng, lat = _drop_reasons(table, parsed)
    pa.default_memory_pool().release_unused()
    if cfg.strict and (code.any() or set_aside):
        raise _strict_error(code, parsed, lng, rows, set_aside, path)
    keep = code == 0
    idx = np.flatnonzero(keep)
    kept = table.take(idx)
    aoi = (
        _strings(kept["aoi_id"])
        if "aoi_id" in kept.column_names
        else np.full(idx.size, "", dtype=object)
    )
    weight = parsed["weight_kg"][keep] if "weight_kg" in parsed else None
    counts = np.bincount(code, minlength=len(DROP_REASONS) + 1)
    for _, reason, _ in set_aside:
        counts[_code(reason)] += 1
    report = DropReport(
        total=int(code.size) + len(set_aside),
        kept=int(idx.size),
        dropped={r: int(counts[k + 1]) for k, r in enumerate(DROP_REASONS)},
        ds_other_day=(
            ds_other_day(parsed["ds"][keep], parsed["delivery_time"][keep]) if "ds" in parsed else 0
        ),
        swapped_coordinates=_swapped(code, lng, lat),
        over_new_year=_over_new_year(code, parsed),
        decimal_comma=_decimal_commas(code, table),
    )
    return LadeTable(
        order_id=_strings(kept["order_id"]),
        lng=lng[keep],
        lat=lat[keep],
        accept_s=parsed["accept_time"][keep],
        delivery_s=parsed["delivery_time"][keep],
        aoi_id=aoi,
        weight_kg=weight,
        row=rows[idx],
        source=source(),
        report=report,
        **_instants(parsed, keep, cfg.tz),
    )


def _instants(parsed: dict[str, np.ndarray], keep: np.ndarray, tz: str) -> dict[str, np.ndarray]:
    """``accept_at`` and ``delivery_at`` of the kept rows (:class:`LadeTable`) when a
    time of the file carried its zone: its own instant where it did, its wall clock's in
    ``tz`` where not; nothing when none did (the wall clock is all there is)."""
    if not any(parsed[f"{name}_time_zoned"][keep].any() for name in ("accept", "delivery")):
        return {}
    out = {}
    for name in ("accept", "delivery"):
        zoned, wall = parsed[f"{name}_time_zoned"][keep], parsed[f"{name}_time"][keep]
        out[f"{name}_at"] = np.where(zoned, parsed[f"{name}_time_utc"][keep], instants(wall, tz))
    return out
