"""Day specs on the command line and the vectorised time/ds parsers."""

from __future__ import annotations

import datetime as dt
import warnings
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

from marops_cli.data.dates import (
    MAX_DAYS,
    TIME_BAD,
    TIME_EMPTY,
    TIME_OK,
    format_days,
    parse_day,
    parse_days,
    parse_ds,
    parse_times,
    split_by_date,
)
from marops_cli.errors import InputError

AUG20 = dt.date(2022, 8, 20)


@pytest.mark.parametrize("text", ["820", "0820", "08-20", "2022-08-20", "20220820", " 820 "])
def test_parse_day_forms(text: str) -> None:
    assert parse_day(text, 2022) == AUG20


def test_parse_day_uses_year_only_when_missing() -> None:
    assert parse_day("820", 2023) == dt.date(2023, 8, 20)
    assert parse_day("2021-08-20", 2023) == dt.date(2021, 8, 20)


@pytest.mark.parametrize("text", ["0230", "1301", "aug 20", "", "82", "2022-13-01", "12345"])
def test_parse_day_bad_names_the_value(text: str) -> None:
    with pytest.raises(InputError) as err:
        parse_day(text, 2022)
    assert repr(text) in str(err.value)
    assert err.value.exit_code == 2


def test_parse_day_leap_year_follows_the_setting() -> None:
    assert parse_day("0229", 2024) == dt.date(2024, 2, 29)
    # The form is right: the error says the year is not (--date 0229 over 2024's days).
    with pytest.raises(InputError, match=r"'0229': February 29 is no day of 2022, .*\(--year\)"):
        parse_day("0229", 2022)
    with pytest.raises(InputError, match=r"got '2023-02-29'$"):
        parse_day("2023-02-29", 2024)


def test_parse_days_list_and_range() -> None:
    assert parse_days("0820,0821", 2022) == [AUG20, dt.date(2022, 8, 21)]
    days = parse_days("0820..0827", 2022)
    assert days[0] == AUG20 and days[-1] == dt.date(2022, 8, 27) and len(days) == 8
    # Ranges across a month end, mixed with single days; repeats listed once, order kept.
    assert parse_days("0831..901,820,0831", 2022) == [
        dt.date(2022, 8, 31),
        dt.date(2022, 9, 1),
        AUG20,
    ]


@pytest.mark.parametrize("spec", ["0827..0820", "0820,,0821", "", "0820..x"])
def test_parse_days_bad(spec: str) -> None:
    with pytest.raises(InputError) as err:
        parse_days(spec, 2022)
    assert not str(err.value).startswith("invalid option")
    with pytest.raises(InputError, match=r"^invalid option --dates: expected a"):
        parse_days(spec, 2022, "--dates")  # the option that gave it, as the commands name it


def test_a_range_over_the_new_year_says_how_to_write_it() -> None:
    """``1230..0102`` takes 2022 for both ends, so it ends before it starts: the error
    says so and gives the range in full; a range given backwards gets no such hint."""
    with pytest.raises(InputError) as err:
        parse_days("1230..0102", 2022, "--dates")
    assert str(err.value) == (
        "invalid option --dates: expected a range from an earlier to a later date, got "
        "'1230..0102' (days without a year are in 2022: over the new year, write "
        "2022-12-30..2023-01-02)"
    )
    with pytest.raises(InputError) as err:
        parse_days("0827..0820", 2022)
    assert "new year" not in str(err.value)
    with pytest.raises(InputError) as err:
        parse_days("2022-12-30..2022-01-02", 2022)
    assert "new year" not in str(err.value)
    assert parse_days("2022-12-31..2023-01-01", 2022) == [
        dt.date(2022, 12, 31),
        dt.date(2023, 1, 1),
    ]


def test_cli_names_the_date_option(example_csv: Path, tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    args = ["replay-day", str(example_csv), "--date", "13", "--out", str(tmp_path / "o")]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 2 and not (tmp_path / "o").exists()
    assert res.stderr.startswith("marops: error: invalid option --date: expected a date like")


def test_format_days() -> None:
    month = [dt.date(2022, 8, d) for d in range(30, 0, -1)]
    assert format_days(month) == "2022-08-01..2022-08-30"
    assert format_days([dt.date(2022, 8, 30), dt.date(2022, 8, 1)]) == "2022-08-01, 2022-08-30"
    assert format_days([AUG20]) == "2022-08-20"
    assert format_days([]) == "no dates"
    # A day missing in the middle shows (it read "2022-08-01..2022-08-05" before).
    gap = [dt.date(2022, 8, d) for d in (5, 1, 2, 4, 2)]
    assert format_days(gap) == "2022-08-01..2022-08-02, 2022-08-04..2022-08-05"
    # Past ``most`` runs, the rest are counted: every other day of August.
    odd = [dt.date(2022, 8, d) for d in range(1, 32, 2)]
    assert format_days(odd, most=2) == "2022-08-01, 2022-08-03 and 14 more days"
    assert format_days(odd[:3], most=2) == "2022-08-01, 2022-08-03 and 1 more day"


def test_parse_times_formats_and_status() -> None:
    col = pa.chunked_array(
        [
            ["08-20 10:31:05", "2022-08-20 10:31:05", " 08-20 10:31:05 ", None],
            ["", "02-29 10:00:00", "08-20 24:00:00", "08-20 10:31:05x", "20 Aug 10:31"],
        ]
    )
    secs, status = parse_times(col, 2022)
    expect = np.datetime64("2022-08-20T10:31:05", "s").astype(np.int64)
    np.testing.assert_array_equal(secs[:3], [expect] * 3)
    np.testing.assert_array_equal(status, [TIME_OK] * 3 + [TIME_EMPTY] * 2 + [TIME_BAD] * 4)


def test_parse_times_missing_value_markers_are_empty() -> None:
    # What exports write for a missing value is an empty time, not a bad one.
    markers = ["NULL", "null", "\\N", "NaN", "None", "--", " NaT ", "\\n"]
    secs, status = parse_times(pa.array([*markers, "nul", "-", "N", "08-20 10:31:05"]), 2022)
    np.testing.assert_array_equal(status, [TIME_EMPTY] * len(markers) + [TIME_BAD] * 3 + [TIME_OK])
    assert (secs[:-1] == 0).all()


def test_parse_times_lenient_forms_of_other_exporters() -> None:
    # Unpadded fields, slashes, no seconds, fractional seconds: read, not rejected.
    col = pa.array(
        ["8-20 9:05:00", "2022/08/20 10:31:05", "08-20 10:31", "08-20 10:31:05.250", "8/2 7:00"]
    )
    secs, status = parse_times(col, 2022)
    assert (status == TIME_OK).all()
    expect = np.array(
        [
            "2022-08-20T09:05:00",
            "2022-08-20T10:31:05",
            "2022-08-20T10:31:00",
            "2022-08-20T10:31:05",
            "2022-08-02T07:00:00",
        ],
        dtype="datetime64[s]",
    ).astype(np.int64)
    np.testing.assert_array_equal(secs, expect)


def test_parse_times_matches_numpy_datetime() -> None:
    # Every minute-ish over a year, in both formats: equals numpy's own parse.
    stamps = np.arange(
        np.datetime64("2024-01-01T00:00:07"), np.datetime64("2025-01-01T00:00:00"), 3607
    )
    full = pa.array([str(s).replace("T", " ") for s in stamps])
    short = pa.array([str(s)[5:].replace("T", " ") for s in stamps])
    expect = stamps.astype("datetime64[s]").astype(np.int64)
    for col in (full, short):
        secs, status = parse_times(col, 2024)
        assert (status == TIME_OK).all()
        np.testing.assert_array_equal(secs, expect)


def test_parse_times_timestamp_column() -> None:
    col = pa.array([dt.datetime(2022, 8, 20, 10, 31, 5), None], pa.timestamp("ms"))
    secs, status = parse_times(col, 2022)
    assert secs[0] == np.datetime64("2022-08-20T10:31:05", "s").astype(np.int64)
    np.testing.assert_array_equal(status, [TIME_OK, TIME_EMPTY])


def test_parse_ds() -> None:
    text = pa.array(["820", "0820", "1231", "20220820", "1301", "0230", "", None, "x", " 820"])
    np.testing.assert_array_equal(parse_ds(text, 2022), [True] * 4 + [False] * 5 + [True])
    np.testing.assert_array_equal(parse_ds(pa.array([820, 229, None]), 2022), [True, False, False])


def test_parse_ds_of_floats_beyond_any_integer_warns_of_nothing() -> None:
    """A float ``ds`` column (pandas re-saved it) with 1e30 in it: not a date, and no
    numpy warning of a cast (it would print a second line before the error's one)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got = parse_ds(pa.array([820.0, 1e30, -1e30, 820.5, None]), 2022)
    np.testing.assert_array_equal(got, [True, False, False, False, False])


def _dates(n: int) -> list[dt.date]:
    return [dt.date(2022, 8, 1) + dt.timedelta(days=i) for i in range(n)]


# (dates in the file, held out): 20 % rounded half up, at least one on each side.
@pytest.mark.parametrize(
    ("n", "n_held"), [(1, 0), (2, 1), (3, 1), (8, 2), (10, 2), (12, 2), (13, 3), (50, 10)]
)
def test_split_by_date_holds_out_the_last_fifth(n: int, n_held: int) -> None:
    days = _dates(n)
    first, last = split_by_date(reversed(days))  # any order in, sorted out
    assert first == days[: n - n_held] and last == days[n - n_held :]


def test_split_by_date_keeps_the_days_of_the_former_training_rule() -> None:
    """Training once kept the first round(0.8 n) dates (at least one, not all of them)."""
    for n in range(2, 400):
        n_train = min(n - 1, max(1, round(0.8 * n)))
        assert len(split_by_date(_dates(n))[0]) == n_train, n


def test_parse_days_refuses_more_days_than_a_run_takes() -> None:
    """A range of millions of days is refused before it is listed (a run checks every
    day's outputs before it reads the file); ten years are taken, repeats counted once."""
    with pytest.raises(InputError, match=r"^invalid option --dates: 3,652,059 days in "):
        parse_days("00010101..99991231", 2022, "--dates")
    with pytest.raises(InputError, match=rf"more days in .*more than the {MAX_DAYS:,}"):
        parse_days("2000-01-01..2009-12-31,2010-01-01..2010-12-31", 2022)
    assert len(parse_days("2000-01-01..2009-12-31", 2022)) == 3653
    assert len(parse_days(",".join(["2000-01-01..2009-12-31"] * 3), 2022)) == 3653


def test_cli_refuses_a_range_of_millions_of_days_at_once(example_csv: Path, tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    out = tmp_path / "o"
    args = ["replay-day", str(example_csv), "--dates", "00010101..99991231", "--out", str(out)]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 2 and not out.exists()
    assert res.stderr.startswith("marops: error: invalid option --dates: 3,652,059 days")
    assert res.stderr.count("\n") == 1


@pytest.mark.parametrize("digits", ["٠١٢٣٤٥٦٧٨٩", "０１２３４５６７８９", "۰۱۲۳۴۵۶۷۸۹"])
def test_days_and_times_take_ascii_digits_only(digits: str) -> None:
    """A time or a day in other digits (Arabic-Indic, full-width) is no time or day, as
    a ds of them is none: int() would read them, so the lenient forms took them."""
    other = str.maketrans("0123456789", digits)
    cells = ["08-20 10:31:05", "8-20 9:05:00", "2022/08/20 10:31"]
    secs, status = parse_times(pa.array([c.translate(other) for c in cells]), 2022)
    np.testing.assert_array_equal(status, [TIME_BAD] * 3)
    assert (secs == 0).all()
    for day in ("0820", "08-20", "20220820", "2022-08-20"):
        with pytest.raises(InputError, match=r"^invalid option --date: expected a date"):
            parse_day(day.translate(other), 2022, "--date")
