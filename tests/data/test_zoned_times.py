"""Times that carry their zone: text times with a UTC offset read as zone-aware Parquet
times do, and a zone-aware row is checked in absolute time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
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


def _london_parquet(path: Path, accept_utc: list[str], delivery_utc: list[str]) -> Path:
    """Rows in London with zone-aware times (the instants given, in UTC)."""
    n = len(accept_utc)
    ts = pa.timestamp("s", tz="Europe/London")

    def instants(texts: list[str]) -> pa.Array:
        return pa.array(np.array(texts, dtype="datetime64[s]"), pa.timestamp("s")).cast(ts)

    pq.write_table(
        pa.table(
            {
                "order_id": [str(i) for i in range(n)],
                "lng": [-0.12] * n,
                "lat": [51.5] * n,
                "accept_time": instants(accept_utc),
                "delivery_time": instants(delivery_utc),
            }
        ),
        path,
    )
    return path


def test_delivered_after_accepted_over_the_autumn_clock_change_is_kept(tmp_path: Path) -> None:
    """Accepted 01:50 BST (00:50 UTC) and delivered 01:10 GMT (01:10 UTC) on 30 October
    2022: 20 minutes later, though the wall clock reads 40 minutes earlier. Kept; an
    order delivered 01:10 BST, before it was accepted, is still dropped."""
    path = _london_parquet(
        tmp_path / "london.parquet",
        ["2022-10-30T00:50:00", "2022-10-30T00:50:00"],
        ["2022-10-30T01:10:00", "2022-10-30T00:10:00"],
    )
    got = read_lade(path, DataConfig(tz="Europe/London"))
    assert list(got.order_id) == ["0"]
    assert got.report.to_dict()["dropped"]["delivery_before_accept"] == 1
    # Wall-clock times, as every other time is read.
    assert got.accept_s[0] == sec("2022-10-30T01:50:00")
    assert got.delivery_s[0] == sec("2022-10-30T01:10:00")
    # The same rows in text with their offsets read the same.
    rows = [
        row("0", "-0.12", "51.5", "2022-10-30 01:50:00+01:00", "2022-10-30 01:10:00+00:00"),
        row("1", "-0.12", "51.5", "2022-10-30 01:50:00+01:00", "2022-10-30 01:10:00+01:00"),
    ]
    text = read_lade(write_csv(tmp_path / "london.csv", rows), DataConfig(tz="Europe/London"))
    assert list(text.order_id) == ["0"]
    np.testing.assert_array_equal(text.delivery_s, got.delivery_s)


def test_read_lade_gives_a_zoned_time_of_the_repeated_hour_its_own_instant(
    tmp_path: Path,
) -> None:
    """The API's table holds the instant a zone-aware time names: 01:10 GMT (01:10 UTC),
    not the first 01:10 of the night (00:10 UTC), which would read as delivered 40
    minutes before it was accepted."""
    import marops_cli.api as marops

    path = _london_parquet(
        tmp_path / "london.parquet", ["2022-10-30T00:50:00"], ["2022-10-30T01:10:00"]
    )
    rows = marops.read_lade(path, tz="Europe/London")
    utc = pa.timestamp("s", tz="UTC")
    assert rows["delivery_time"].cast(utc).to_pylist()[0].isoformat() == "2022-10-30T01:10:00+00:00"
    assert rows["accept_time"].cast(utc).to_pylist()[0].isoformat() == "2022-10-30T00:50:00+00:00"
    assert rows.schema.field("delivery_time").type == pa.timestamp("s", tz="Europe/London")
