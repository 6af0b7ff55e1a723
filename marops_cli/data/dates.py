"""Dates and times in LaDe's formats (docs/method.md §1).

A day on the command line is ``820``, ``0820``, ``08-20``, ``20220820`` or
``2022-08-20``; several are given as ``0820,0821`` or as an inclusive range
``0820..0827``. In the files, times are ``MM-DD HH:MM:SS`` (the year is a
setting) or ``YYYY-MM-DD HH:MM:SS``, and ``ds`` is the date as an integer
``MMDD``. The column parsers here are vectorised: a LaDe city file has
1.5 million rows, too many for a Python loop.
"""

from __future__ import annotations

import datetime as dt
import math
import re
from collections.abc import Iterable
from typing import NamedTuple

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from ..errors import InputError
from .arrow import is_text

# (pattern, whether it carries the year); ASCII digits only, as in the files (``\d``
# alone also matches Arabic-Indic and full-width digits, which int() reads).
_DAY_FORMS = (
    (re.compile(r"(\d{1,2})(\d{2})", re.ASCII), False),  # 820, 0820
    (re.compile(r"(\d{1,2})-(\d{1,2})", re.ASCII), False),  # 08-20
    (re.compile(r"(\d{4})(\d{2})(\d{2})", re.ASCII), True),  # 20220820
    (re.compile(r"(\d{4})-(\d{1,2})-(\d{1,2})", re.ASCII), True),  # 2022-08-20
)
_EXPECTED_DAY = "expected a date like 820, 0820 or 2022-08-20"

_DAY_S = 86_400

# Parse status of a time cell.
TIME_OK, TIME_EMPTY, TIME_BAD = 0, 1, 2


def parse_day(
    text: str, year: int, option: str | None = None, *, year_option: str | None = "--year"
) -> dt.date:
    """``"820"``, ``"0820"``, ``"08-20"``, ``"20220820"`` or ``"2022-08-20"`` -> a date.

    Forms without a year take ``year`` (set by ``year_option``; None: by no option, so
    February 29 asks for the year to be written). Raises :class:`InputError` naming the
    value (and the ``option`` that gave it, e.g. ``--date``) when it is not a valid date.
    """
    s = str(text).strip()
    for pattern, has_year in _DAY_FORMS:
        m = pattern.fullmatch(s)
        if m is None:
            continue
        parts = [int(g) for g in m.groups()]
        y = parts.pop(0) if has_year else year
        try:
            return dt.date(y, parts[0], parts[1])
        except ValueError:
            if parts == [2, 29] and not has_year:  # the form is right, the year is not
                leap = f": February 29 is no day of {year}, the year of days without one"
                leap += f" ({year_option})" if year_option else "; write a leap year's, 2024-02-29"
                raise _bad(f"{_EXPECTED_DAY}, got {text!r}{leap}", option) from None
            break
    raise _bad(f"{_EXPECTED_DAY}, got {text!r}{_range_hint(s, year)}", option)


def _bad(message: str, option: str | None) -> InputError:
    """The error of a bad date, naming the option that gave it when there is one."""
    return InputError(f"invalid option {option}: {message}" if option else message)


def _range_hint(text: str, year: int) -> str:
    """``; a range of days is written 0801..0810`` when ``text`` reads as two days
    joined by ``-`` (``0801-0810``), else nothing."""
    for i, ch in enumerate(text):
        if ch != "-":
            continue
        first, last = text[:i], text[i + 1 :]
        try:
            parse_day(first, year), parse_day(last, year)
        except InputError:
            continue
        return f"; a range of days is written {first}..{last}"
    return ""


def _over_new_year(start: dt.date, end: dt.date, last: str, year: int) -> str:
    """What a range that ends before it starts (``1230..0102``) meant when its end has no
    year and is, in the next year, less than half a year after its start: both ends
    took ``year``."""
    if len(last.strip()) > 5:  # 2023-01-02: a year of its own
        return ""
    try:
        nxt = end.replace(year=year + 1)
    except ValueError:  # 29 February
        return ""
    if (nxt - start).days > 183:  # 0827..0820: a range given backwards
        return ""
    return (
        f" (days without a year are in {year}: over the new year, write "
        f"{start.isoformat()}..{nxt.isoformat()})"
    )


MAX_DAYS = 3660
"""Days one list of days may hold (ten years and more): a run checks the outputs of
every day it names before it reads anything, so ``00010101..99991231`` (3.6 million
days) would keep it busy for an hour before it found no such day in the file."""


def parse_days(spec: str, year: int, option: str | None = None) -> list[dt.date]:
    """``"0820,0821"`` or ``"0820..0827"`` (inclusive), mixed freely -> dates.

    Dates keep the order given; a repeated date is listed once. Errors name ``option``
    (e.g. ``--dates``) when given; more than :data:`MAX_DAYS` days are refused before
    they are listed.
    """
    days: dict[dt.date, None] = {}
    for item in str(spec).split(","):
        item = item.strip()
        if not item:
            raise _bad(f"{_EXPECTED_DAY} in the list of days, got {spec!r}", option)
        first, sep, last = item.partition("..")
        start = parse_day(first, year, option)
        end = parse_day(last, year, option) if sep else start
        if end < start:
            over = _over_new_year(start, end, last, year)
            raise _bad(
                f"expected a range from an earlier to a later date, got {item!r}{over}", option
            )
        n = (end - start).days + 1
        if n <= MAX_DAYS:
            days.update(dict.fromkeys(start + dt.timedelta(days=i) for i in range(n)))
        if n > MAX_DAYS or len(days) > MAX_DAYS:
            many = f"{n:,} days in {item!r}" if n > MAX_DAYS else f"more days in {spec!r}"
            raise _bad(f"{many}, more than the {MAX_DAYS:,} (ten years) one run takes", option)
    return list(days)


def format_days(days: Iterable[dt.date], most: int = 6) -> str:
    """The days as runs of consecutive days, in date order (``2022-08-01..2022-08-08,
    2022-08-12``), so a gap shows; past ``most`` runs, the first of them and how many
    days the rest hold; ``no dates`` when there are none."""
    runs: list[list[dt.date]] = []
    for d in sorted(set(days)):
        if runs and d - runs[-1][-1] == dt.timedelta(days=1):
            runs[-1].append(d)
        else:
            runs.append([d])
    if not runs:
        return "no dates"
    shown = [r[0].isoformat() if len(r) == 1 else f"{r[0]}..{r[-1]}" for r in runs[:most]]
    rest = sum(len(r) for r in runs[most:])
    return ", ".join(shown) + (f" and {rest} more day{'s' * (rest != 1)}" if rest else "")


HELD_OUT_SHARE = 0.2  # docs/method.md §6: 80 % / 20 % split by date


def split_by_date(days: Iterable[dt.date]) -> tuple[list[dt.date], list[dt.date]]:
    """(the first 80 % of the dates, the last 20 %), both sorted (docs/method.md §6).

    The held-out count is 20 % of the dates rounded half up, and with two dates or more
    each side keeps at least one. With fewer than two, every date is in the first part.
    ``marops train`` (training / held-out days) and ``marops evaluate --split`` both use it.
    """
    days = sorted(days)
    if len(days) < 2:
        return days, []
    n_held = min(len(days) - 1, max(1, math.floor(HELD_OUT_SHARE * len(days) + 0.5)))
    return days[:-n_held], days[-n_held:]


_MONTH_DAYS = np.array([0, 31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31], dtype=np.int64)


def _days_from_civil(year: np.ndarray, month: np.ndarray, day: np.ndarray) -> np.ndarray:
    """Days since 1970-01-01 of valid proleptic-Gregorian dates.

    Integer arithmetic (H. Hinnant's days_from_civil): numpy's datetime64[M] ->
    [D] cast walks the calendar per element and is several times slower.
    """
    y = year - (month <= 2)
    era = y // 400
    yoe = y - era * 400
    doy = (153 * np.where(month > 2, month - 3, month + 9) + 2) // 5 + day - 1
    return era * 146_097 + yoe * 365 + yoe // 4 - yoe // 100 + doy - 719_468


def _valid_ymd(year: np.ndarray, month: np.ndarray, day: np.ndarray) -> np.ndarray:
    """Mask of (year, month, day) triples that name a real calendar day."""
    ok = (month >= 1) & (month <= 12) & (day >= 1) & (year >= 1)
    leap = (year % 4 == 0) & ((year % 100 != 0) | (year % 400 == 0))
    last = _MONTH_DAYS[np.where(ok, month, 0)] + ((month == 2) & leap)
    return ok & (day <= last)


# Seconds of 0001-01-01 00:00:00 and 9999-12-31 23:59:59 since 1970-01-01.
_FIRST_S = (dt.datetime.min - dt.datetime(1970, 1, 1)) // dt.timedelta(seconds=1)
_LAST_S = (dt.datetime(9999, 12, 31, 23, 59, 59) - dt.datetime(1970, 1, 1)) // dt.timedelta(
    seconds=1
)


def _string_bytes(arr: pa.Array) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(data bytes, start offset, length, is-null) of a string array, without copying rows."""
    arr = arr.cast(pa.large_string()) if arr.type != pa.large_string() else arr
    _, off_buf, data_buf = arr.buffers()
    offsets = np.frombuffer(off_buf, dtype=np.int64)[arr.offset : arr.offset + len(arr) + 1]
    data = np.zeros(0, np.uint8) if data_buf is None else np.frombuffer(data_buf, dtype=np.uint8)
    isnull = arr.is_null().to_numpy(zero_copy_only=False)
    return data, offsets[:-1], np.diff(offsets), isnull


def parse_times(
    column: pa.ChunkedArray | pa.Array, year: int, tz: str = "Asia/Shanghai"
) -> tuple[np.ndarray, np.ndarray]:
    """A column of times -> (seconds, status): :func:`read_times` without the offsets."""
    times = read_times(column, year, tz)
    return times.secs, times.status


class Times(NamedTuple):
    """A column of times as :func:`read_times` reads it."""

    secs: np.ndarray
    """Naive wall-clock seconds in the data's zone since 1970-01-01 (0 where not OK)."""
    status: np.ndarray
    """:data:`TIME_OK`, :data:`TIME_EMPTY` or :data:`TIME_BAD` per row."""
    offset: np.ndarray
    """Seconds the wall clock is ahead of UTC, where the cell carried its zone or offset
    (0 elsewhere): ``secs - offset`` is the absolute time."""
    zoned: np.ndarray
    """Whether the cell carried its zone or offset, so its absolute time is known."""


def read_times(
    column: pa.ChunkedArray | pa.Array, year: int, tz: str = "Asia/Shanghai", offsets: bool = True
) -> Times:
    """A column of ``MM-DD HH:MM:SS`` / ``YYYY-MM-DD HH:MM:SS`` strings -> (seconds, status).

    Seconds are naive local time since 1970-01-01 (int64, 0 where not OK);
    status is :data:`TIME_OK`, :data:`TIME_EMPTY` (null, blank, or a marker exports
    write for a missing value, such as ``NULL`` or ``\\N``: :data:`MISSING_MARKERS`) or
    :data:`TIME_BAD` per row. Parsing is strict: ``02-30`` or ``24:00:00`` is bad
    (pyarrow's strptime would roll the first over to March). A timestamp column
    (from Parquet) is taken as it is when it has no zone, and as the wall-clock time
    in ``tz`` (the data's zone) when it has one, so a zone-aware export reads like the
    CSV of the same rows; one outside the years 1-9999 is bad. A text time that ends
    in its UTC offset (``2022-08-11 08:30:00+08:00``, ``+0800``, ``+08`` or ``Z``) is
    read the same way as a zone-aware timestamp: the instant it names, as wall-clock
    time in ``tz``. Where a cell carried its zone, ``offset`` and ``zoned`` say how far
    its wall clock is ahead of UTC (``offsets=False``: an offset is a bad time).
    """
    arr = column.combine_chunks() if isinstance(column, pa.ChunkedArray) else column
    n = len(arr)
    offset, zoned = np.zeros(n, np.int64), np.zeros(n, bool)
    if pa.types.is_timestamp(arr.type):
        empty = arr.is_null().to_numpy(zero_copy_only=False)
        try:
            if arr.type.tz is not None:
                # Whole seconds, as the text times have: a fraction (pandas writes milli-
                # and microseconds) is dropped, not refused.
                utc = pc.cast(arr, pa.timestamp("s", tz=arr.type.tz), safe=False)
                secs, offset = _in_zone(utc, tz)
                zoned = ~empty
            else:
                secs = pc.cast(arr, pa.timestamp("s"), safe=False).cast(pa.int64())
        except pa.ArrowInvalid:  # a time the zone database cannot place: no time
            status = np.where(empty, TIME_EMPTY, TIME_BAD).astype(np.int8)
            return Times(np.zeros(n, np.int64), status, offset, np.zeros(n, bool))
        values = secs.fill_null(0).to_numpy()
        # A time outside the years 1-9999 has no date (the text form cannot write one).
        bad = ~empty & ((values < _FIRST_S) | (values > _LAST_S))
        status = np.where(empty, TIME_EMPTY, np.where(bad, TIME_BAD, TIME_OK)).astype(np.int8)
        return Times(np.where(bad, 0, values), status, np.where(bad, 0, offset), zoned & ~bad)
    if not is_text(arr.type):
        arr = arr.cast(pa.string())
    data, start, length, isnull = _string_bytes(arr)
    # Real exports have no padding, but a hand-edited file may; trimming is cheap.
    filled = length > 0
    if np.any(data[start[filled]] == 32) or np.any(data[(start + length - 1)[filled]] == 32):
        data, start, length, isnull = _string_bytes(pc.utf8_trim_whitespace(arr))
    full = length == 19
    shaped = full | (length == 14)
    # A short MM-DD form lines up with the full form shifted by the 5 chars of "YYYY-".
    base = np.where(full, start, start - 5)
    chars = np.zeros((19, start.size), dtype=np.uint8)  # one byte per cell, position-major
    if data.size:
        for pos in range(19):
            chars[pos] = data[np.clip(base + pos, 0, data.size - 1)]
    digits = chars - np.uint8(48)  # non-digits wrap around to values above 9
    is_digit = digits <= 9

    def number(first: int, n: int) -> np.ndarray:
        # int32: four digits at most, and half the memory of int64 over 1.5 M rows
        value = np.zeros(start.size, np.int32)
        for pos in range(first, first + n):
            value = value * 10 + digits[pos].astype(np.int32)
        return value

    ok = shaped & is_digit[[5, 6, 8, 9, 11, 12, 14, 15, 17, 18]].all(axis=0)
    ok &= ~full | (is_digit[:4].all(axis=0) & (chars[4] == ord("-")))
    ok &= (chars[7] == ord("-")) & ((chars[10] == ord(" ")) | (chars[10] == ord("T")))
    ok &= (chars[13] == ord(":")) & (chars[16] == ord(":"))
    yr = np.where(full, number(0, 4), np.int32(year))
    mo, dd, hh, mi, ss = (number(p, 2) for p in (5, 8, 11, 14, 17))
    ok &= (hh < 24) & (mi < 60) & (ss < 60)
    yr, mo = np.where(ok, yr, np.int32(1970)), np.where(ok, mo, np.int32(1))
    ok &= _valid_ymd(yr, mo, np.where(ok, dd, 1))
    days = _days_from_civil(yr, np.where(ok, mo, np.int32(1)), np.where(ok, dd, np.int32(1)))
    secs = days.astype(np.int64) * 86_400 + (hh * 3600 + mi * 60 + ss)
    secs[~ok] = 0
    empty = isnull | (length == 0)
    status = np.full(start.size, TIME_BAD, dtype=np.int8)
    status[ok] = TIME_OK
    status[empty] = TIME_EMPTY
    bad = np.flatnonzero(status == TIME_BAD)
    if bad.size:
        marker = _missing_marker(arr.take(pa.array(bad)))
        status[bad[marker]] = TIME_EMPTY
        bad = bad[~marker]
    if bad.size and offsets:
        bad = _with_offset(arr, bad, year, tz, Times(secs, status, offset, zoned))
    if bad.size:
        _lenient(arr, bad, year, secs, status)
    return Times(secs, status, offset, zoned)


def _in_zone(instants: pa.Array, tz: str) -> tuple[pa.Array, np.ndarray]:
    """(wall-clock seconds in ``tz``, as int64 with the nulls kept; seconds that wall
    clock is ahead of UTC, 0 where null) of zone-aware timestamps in whole seconds.
    Raises ``pa.ArrowInvalid`` for a time the zone database cannot place."""
    local = pc.local_timestamp(instants.cast(pa.timestamp("s", tz=tz))).cast(pa.int64())
    utc = instants.cast(pa.timestamp("s")).cast(pa.int64())
    ahead = pc.subtract(local, utc).fill_null(0).to_numpy(zero_copy_only=False)
    return local, ahead


# A time with its UTC offset: ``...08:30:00+08:00``, ``+0800``, ``+08`` or ``Z`` (RFC 3339
# and ISO 8601 write these); the time before it is read as any other.
_OFFSET = (
    r"^\s*(?P<time>[^+Zz]*?\d:\d{2}(?::\d{2}(?:\.\d+)?)?)\s*"
    r"(?:(?P<z>[Zz])|(?P<sign>[+-])(?P<hh>\d{2})(?::?(?P<mm>\d{2}))?)\s*$"
)
_MAX_OFFSET_S = 18 * 3600  # the most any zone is or was ahead of or behind UTC, and more


def _with_offset(arr: pa.Array, rows: np.ndarray, year: int, tz: str, times: Times) -> np.ndarray:
    """Read, in place in ``times``, the cells of ``rows`` (rejected so far) that end in
    their UTC offset, as the instant they name in ``tz``'s wall clock (as a zone-aware
    Parquet time is read: :func:`_in_zone`); returns the rows still rejected."""
    cells = arr.take(pa.array(rows))
    if not is_text(cells.type):
        cells = cells.cast(pa.string())
    found = pc.extract_regex(cells, _OFFSET)
    has = pc.is_valid(found).to_numpy(zero_copy_only=False)
    if not has.any():
        return rows
    found = found.filter(pa.array(has))
    head = read_times(pc.struct_field(found, [0]), year, tz, offsets=False)
    sign = np.where(pc.struct_field(found, [2]).to_numpy(zero_copy_only=False) == "-", -1, 1)
    hh, mm = (
        pc.cast(pc.if_else(pc.equal(f, ""), "0", f).fill_null("0"), pa.int64()).to_numpy()
        for f in (pc.struct_field(found, [3]), pc.struct_field(found, [4]))
    )
    ahead = sign * (hh * 3600 + mm * 60)
    ok = (head.status == TIME_OK) & (mm < 60) & (np.abs(ahead) <= _MAX_OFFSET_S)
    at = rows[has][ok]
    instants = pa.array(head.secs[ok] - ahead[ok], pa.timestamp("s", tz="UTC"))
    try:
        local, shift = _in_zone(instants, tz)
    except pa.ArrowInvalid:  # a time the zone database cannot place: no time
        return rows
    values = local.to_numpy(zero_copy_only=False)
    inside = (values >= _FIRST_S) & (values <= _LAST_S)
    at, values, shift = at[inside], values[inside], shift[inside]
    times.secs[at], times.offset[at], times.zoned[at] = values, shift, True
    times.status[at] = TIME_OK
    return rows[times.status[rows] == TIME_BAD]


def instants(wall_s: np.ndarray, tz: str) -> np.ndarray:
    """Seconds since 1970-01-01 UTC of naive wall-clock seconds in zone ``tz``. A wall
    time a clock change repeats is the earlier (the first 01:30 of the night the clocks
    go back); one it skips is the change's instant (01:30 of the night they go forward
    is 02:00, when the clock reaches it). A day whose clock does not change is shifted
    by its offset at once; only the rows of a day it changes are looked up each."""
    wall = np.asarray(wall_s, dtype=np.int64)
    if wall.size == 0:
        return wall.copy()
    days, which = day_index(wall // _DAY_S)
    ahead, steady = day_offsets(days, tz)
    out = wall - ahead[which]
    odd = ~steady[which]
    if odd.any():
        out[odd] = _assume(wall[odd], tz)
    return out


def day_index(day: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(days, which)``: the days (since 1970-01-01) of ``day`` and each one's place in
    them, ``days[which] == day``; a file's days, a range of them, found without a sort."""
    day = np.asarray(day, dtype=np.int64)
    if day.size and int(day.max()) - int(day.min()) < 4096:
        first = int(day.min())
        return np.arange(first, int(day.max()) + 1), day - first
    days, which = np.unique(day, return_inverse=True)
    return days, which


def day_offsets(days: np.ndarray, tz: str) -> tuple[np.ndarray, np.ndarray]:
    """Per day (days since 1970-01-01): the seconds ``tz``'s clock is ahead of UTC at its
    start, and whether it is so all day (no clock change from its first second to its
    last, neither of them skipped or repeated)."""
    from zoneinfo import ZoneInfo

    zone = ZoneInfo(tz)
    ahead = np.zeros(days.size, np.int64)
    steady = np.zeros(days.size, bool)
    for k, d in enumerate(days.tolist()):
        start = _EPOCH + dt.timedelta(days=d)
        offsets = {
            when.replace(tzinfo=zone, fold=fold).utcoffset()
            for when in (start, start + dt.timedelta(seconds=_DAY_S - 1))
            for fold in (0, 1)
        }
        first = start.replace(tzinfo=zone).utcoffset()
        ahead[k] = 0 if first is None else first // dt.timedelta(seconds=1)
        steady[k] = len(offsets) == 1
    return ahead, steady


def _assume(wall: np.ndarray, tz: str) -> np.ndarray:
    """:func:`instants` of every one of ``wall``, each looked up in the zone database."""
    at = pc.assume_timezone(
        pa.array(wall.astype("datetime64[s]")), tz, ambiguous="earliest", nonexistent="latest"
    )
    return np.asarray(at.cast(pa.int64()).to_numpy(zero_copy_only=False), dtype=np.int64)


# What exports write for a missing value (SQL and Hive dumps, pandas, spreadsheets),
# compared trimmed and in lower case.
MISSING_MARKERS = ("null", "\\n", "nan", "nat", "none", "--")


def _missing_marker(cells: pa.Array) -> np.ndarray:
    """Mask of the text cells that are a missing-value marker (:data:`MISSING_MARKERS`)."""
    text = pc.utf8_lower(pc.utf8_trim_whitespace(cells))
    found = pc.is_in(text, value_set=pa.array(MISSING_MARKERS, pa.string()))
    return found.fill_null(False).to_numpy(zero_copy_only=False)


# Forms other tools write: 2022/08/20, 8-20 9:05, 10:31 without seconds, 10:31:05.000;
# in ASCII digits, as the fast parser and ds take them.
_LENIENT = re.compile(
    r"^\s*(?:(\d{4})[-/.])?(\d{1,2})[-/.](\d{1,2})[ T](\d{1,2}):(\d{2})(?::(\d{2})(?:\.\d+)?)?\s*$",
    re.ASCII,
)
_EPOCH = dt.datetime(1970, 1, 1)


def _lenient(
    arr: pa.Array, rows: np.ndarray, year: int, secs: np.ndarray, status: np.ndarray
) -> None:
    """Second chance, in place, for the cells the fast parser rejected (few, so a loop is fine).

    Each distinct text is parsed once; a cell that still fails stays :data:`TIME_BAD`.
    """
    texts = arr.take(pa.array(rows)).to_pylist()
    cache: dict[str, int | None] = {}
    for r, text in zip(rows, texts, strict=True):
        if text not in cache:
            m = _LENIENT.match(str(text))
            value = None
            if m:
                y, mo, d, h, mi, sec = m.groups()
                try:
                    when = dt.datetime(
                        int(y or year), int(mo), int(d), int(h), int(mi), int(sec or 0)
                    )
                    value = int((when - _EPOCH).total_seconds())
                except ValueError:
                    value = None
            cache[text] = value
        if cache[text] is not None:
            secs[r] = cache[text]
            status[r] = TIME_OK


def parse_ds(column: pa.ChunkedArray | pa.Array, year: int | np.ndarray) -> np.ndarray:
    """Mask of ``ds`` cells that are a valid ``MMDD`` (or ``YYYYMMDD``) date in ``year``
    (one for every row, or each row's own: :func:`years_of` its delivery time).

    ``ds`` is read as text or as integers (a date or time column as its date); empty,
    non-digit and impossible dates (``231``, ``1301``) are not valid.
    """
    return ds_dates(column, year)[0]


def years_of(secs: np.ndarray) -> np.ndarray:
    """The year of each time (naive seconds since 1970-01-01), as int64."""
    days = (np.asarray(secs) // 86_400).astype("datetime64[D]")
    return days.astype("datetime64[Y]").astype(np.int64) + 1970


def ds_other_day(ds: np.ndarray, delivery_s: np.ndarray) -> int:
    """How many rows have a valid ``ds`` (``ds``: their dates, :func:`ds_dates`; NaT where
    none) of another day than their delivery time (``delivery_s``, naive seconds since
    1970-01-01). A note, not a drop: a request's day is the date of its delivery time
    (docs/decisions.md, "Reading LaDe")."""
    day = (np.asarray(delivery_s) // 86_400).astype("datetime64[D]")
    return int((~np.isnat(ds) & (ds != day)).sum())


def ds_dates(
    column: pa.ChunkedArray | pa.Array, year: int | np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The mask of valid ``ds`` cells (:func:`parse_ds`) and their dates (datetime64[D]),
    NaT where a cell is no valid date or one past the year 9999 (no time's)."""
    arr = column.combine_chunks() if isinstance(column, pa.ChunkedArray) else column
    if pa.types.is_floating(arr.type):  # a column with gaps re-saved by pandas: 820.0
        f = arr.fill_null(-1.0).to_numpy(zero_copy_only=False)
        # Beyond 2**62 no date, and casting it would warn (a second line on stderr).
        whole = np.isfinite(f) & (f == np.floor(f)) & (np.abs(f) < 2.0**62)
        value = np.where(whole, f, -1).astype(np.int64)
    elif pa.types.is_integer(arr.type):
        # An unsigned value past int64 wraps to a negative one, which is no date.
        value = arr.cast(pa.int64(), safe=False).fill_null(-1).to_numpy()
    else:
        if pa.types.is_timestamp(arr.type):  # ds turned into a time by a DataFrame: its date
            arr = arr.cast(pa.date32())
        text = arr.cast(pa.string())
        try:  # fast path: a clean column casts at once
            value = text.cast(pa.int64()).fill_null(-1).to_numpy()
        except pa.ArrowInvalid:
            text = pc.utf8_trim_whitespace(text)
            # 820.0 (pandas) and 2022-08-20 (ISO) are read as 820 and 20220820.
            text = pc.replace_substring_regex(text, r"^(\d{3,4})\.0+$", r"\1")
            text = pc.replace_substring_regex(text, r"^(\d{4})-(\d{2})-(\d{2})$", r"\1\2\3")
            digits = pc.fill_null(pc.match_substring_regex(text, r"^(\d{3,4}|\d{8})$"), False)
            value = pc.if_else(digits, text, None).cast(pa.int64()).fill_null(-1).to_numpy()
    long = value >= 10_000_000
    yr = np.where(long, value // 10_000, year)
    mmdd = np.where(long, value % 10_000, value)
    valid = (value >= 0) & _valid_ymd(yr, mmdd // 100, mmdd % 100)
    ok = valid & (yr <= 9999)
    yr, month, day = (np.where(ok, v, 1) for v in (yr, mmdd // 100, mmdd % 100))
    months = (yr - 1970) * 12 + month - 1
    dates = months.astype("datetime64[M]").astype("datetime64[D]") + (day - 1)
    return valid, np.where(ok, dates, np.datetime64("NaT", "D"))
