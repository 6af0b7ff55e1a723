"""A Parquet export with zone-aware times reads, and plans, exactly like the CSV."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.config import DataConfig
from marops_cli.data.dates import TIME_OK, parse_times
from marops_cli.data.reader import read_lade


def _zoned(example_csv: Path, path: Path, zone: str) -> None:
    """The example's rows with accept/delivery times as timestamps in ``zone`` (the same
    instants as the CSV's Shanghai wall-clock times)."""
    raw = pacsv.read_csv(
        example_csv, convert_options=pacsv.ConvertOptions(column_types={"order_id": pa.string()})
    )
    for name in ("accept_time", "delivery_time"):
        secs, status = parse_times(raw[name], 2022)
        naive = pa.array(np.where(status == TIME_OK, secs, 0).astype("datetime64[s]"))
        naive = pc.if_else(pa.array(status == TIME_OK), naive, pa.scalar(None, naive.type))
        local = pc.assume_timezone(naive, "Asia/Shanghai")  # Shanghai wall clock -> instant
        zoned = local.cast(pa.timestamp("ms", tz=zone))
        raw = raw.set_column(raw.schema.get_field_index(name), name, zoned)
    pq.write_table(raw, path)


@pytest.mark.parametrize("zone", ["Asia/Shanghai", "UTC"])
def test_zone_aware_parquet_reads_like_the_csv(example_csv: Path, tmp_path: Path, zone: str):
    path = tmp_path / "zoned.parquet"
    _zoned(example_csv, path, zone)
    assert pq.read_schema(path).field("delivery_time").type.tz == zone
    a, b = read_lade(example_csv, DataConfig()), read_lade(path, DataConfig())
    assert a.report.to_dict()["kept"] == b.report.to_dict()["kept"]
    np.testing.assert_array_equal(a.order_id, b.order_id)
    np.testing.assert_array_equal(a.accept_s, b.accept_s)
    np.testing.assert_array_equal(a.delivery_s, b.delivery_s)


def test_zone_aware_parquet_plans_what_the_csv_plans(example_csv: Path, tmp_path: Path):
    path = tmp_path / "zoned.parquet"
    _zoned(example_csv, path, "UTC")
    tables = []
    for name, data in (("csv", example_csv), ("pq", path)):
        out = tmp_path / name
        args = ["replay-day", "--area", "square", str(data), "--date", "0811"]
        args += ["--method", "greedy", "--out", str(out)]
        res = CliRunner().invoke(app, args)
        assert res.exit_code == 0, res.output
        tables.append(pq.read_table(out / "stops.parquet").replace_schema_metadata(None))
    assert tables[0].equals(tables[1])
