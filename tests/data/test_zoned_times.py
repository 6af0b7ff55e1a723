"""Times that carry their zone: text times with a UTC offset read as zone-aware Parquet
times do, and a zone-aware row is checked in absolute time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

from marops_cli.config import DataConfig
from marops_cli.data.dates import TIME_BAD, TIME_OK, read_times
from marops_cli.data.reader import read_lade
from marops_cli.errors import InputError
from tests.data.test_reader import CLEAN, row, sec, write_csv


@pytest.mark.parametrize(
    "text",
    [
        "2022-08-20 10:15:00+08:00",
        "2022-08-20 10:15:00+0800",
        "2022-08-20 10:15:00+08",
        "2022-08-20T02:15:00Z",
        "2022-08-20T04:15:00+02:00",
        "2022-08-19 21:15:00-05:00",
        "08-20 02:15:00Z",
    ],
)
def test_a_text_time_with_its_utc_offset_is_its_instant_in_the_datas_zone(text: str) -> None:
    times = read_times(pa.array([text, "08-20 10:15:00"]), 2022, "Asia/Shanghai")
    np.testing.assert_array_equal(times.status, [TIME_OK, TIME_OK])
    np.testing.assert_array_equal(times.secs, [sec("2022-08-20T10:15:00")] * 2)
    np.testing.assert_array_equal(times.zoned, [True, False])
    np.testing.assert_array_equal(times.offset, [8 * 3600, 0])


@pytest.mark.parametrize(
    "text", ["2022-08-20 10:15:00+99:00", "2022-08-20 10:15:00+08:00+08", "2022-08-20+08"]
)
def test_a_bad_offset_is_a_bad_time(text: str) -> None:
    assert read_times(pa.array([text]), 2022).status[0] == TIME_BAD


def test_a_csv_with_utc_offsets_reads_like_the_csv_without(tmp_path: Path) -> None:
    """The rows of CLEAN with their times as the same instants written with an offset
    (Shanghai's, UTC's, another's) read as CLEAN does; LaDe's own form is unchanged."""
    plain = read_lade(write_csv(tmp_path / "plain.csv", CLEAN), DataConfig())
    forms = ("{}+08:00", "{}+0800", "{}+08")
    zoned = [
        {**r, "accept_time": f.format("2022-" + r["accept_time"]), "delivery_time": dlv}
        for r, f, dlv in zip(
            CLEAN,
            forms,
            ["2022-08-20T02:15:00Z", "2022-08-20 04:00:30+01:00", "2022-08-20 20:00:00-05:00"],
            strict=True,
        )
    ]
    got = read_lade(write_csv(tmp_path / "zoned.csv", zoned), DataConfig())
    assert got.report.to_dict()["kept"] == plain.report.to_dict()["kept"] == 3
    np.testing.assert_array_equal(got.accept_s, plain.accept_s)
    np.testing.assert_array_equal(got.delivery_s, plain.delivery_s)
    # In another zone the same instants are that zone's wall clock.
    utc = read_lade(tmp_path / "zoned.csv", DataConfig(tz="UTC"))
    np.testing.assert_array_equal(utc.accept_s, plain.accept_s - 8 * 3600)


def test_a_bad_offset_in_a_csv_is_one_error_naming_the_cell(tmp_path: Path) -> None:
    rows = [*CLEAN[:2], row("1004", dlv="2022-08-20 10:15:00+25:00")]
    with pytest.raises(InputError, match=r"zoned.csv, row 4, column 'delivery_time'"):
        read_lade(write_csv(tmp_path / "zoned.csv", rows), DataConfig())
