"""The synthetic LaDe generator: formats, determinism, quirks, calibration, shape."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq
import pytest
from pydantic import ValidationError

from marops_cli.data.frame import densest_square
from marops_cli.data.synth import SynthConfig, generate, write
from marops_cli.data.table import LADE_COLUMNS

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "shanghai_synth.csv"
TIME_RE = re.compile(r"^\d\d-\d\d \d\d:\d\d:\d\d$")
COORD_RE = re.compile(r"^-?\d+(\.\d{1,6})?$")


@pytest.fixture(scope="module")
def table() -> pa.Table:
    return generate(SynthConfig(days=12, seed=7))


@pytest.fixture(scope="module")
def lines(table: pa.Table, tmp_path_factory: pytest.TempPathFactory) -> list[str]:
    path = write(table, tmp_path_factory.mktemp("synth") / "s.csv")
    return path.read_text().splitlines()


def _col(table: pa.Table, name: str) -> np.ndarray:
    return table[name].to_numpy(zero_copy_only=False)


def _seconds(times: np.ndarray, year: int = 2022) -> np.ndarray:
    """``MM-DD HH:MM:SS`` -> seconds since 1970 in ``year``."""
    iso = np.array([f"{year}-{s[:5]}T{s[6:]}" for s in times])
    return iso.astype("datetime64[s]").astype(np.int64)


def _clean(table: pa.Table) -> np.ndarray:
    """Rows without bad coordinates and with accept <= delivery (duplicates kept)."""
    lng, lat = _col(table, "lng"), _col(table, "lat")
    acc = _seconds(_col(table, "accept_time"))
    dlv = _seconds(_col(table, "delivery_time"))
    return np.isfinite(lng) & np.isfinite(lat) & (lng != 0) & (lat != 0) & (acc <= dlv)


def test_columns_in_file_order(table: pa.Table, lines: list[str]) -> None:
    assert tuple(table.column_names) == LADE_COLUMNS
    assert lines[0] == ",".join(LADE_COLUMNS)  # header unquoted, as in LaDe
    assert all(len(line.split(",")) == 17 for line in lines)
    assert '"' not in "\n".join(lines)


def test_formats(table: pa.Table, lines: list[str]) -> None:
    rows = [line.split(",") for line in lines[1:]]
    idx = {name: i for i, name in enumerate(LADE_COLUMNS)}
    for row in rows:
        for name in ("order_id", "region_id", "courier_id", "aoi_id", "aoi_type", "ds"):
            assert row[idx[name]].isdigit(), (name, row)
        assert row[idx["city"]] == "Shanghai"
        for name in ("accept_time", "delivery_time"):
            assert TIME_RE.match(row[idx[name]]), (name, row)
        for name in ("accept_gps_time", "delivery_gps_time"):
            assert row[idx[name]] == "" or TIME_RE.match(row[idx[name]]), (name, row)
        for name in ("lng", "lat", "accept_gps_lng", "accept_gps_lat"):
            assert row[idx[name]] == "" or COORD_RE.match(row[idx[name]]), (name, row)
        # ds is MMDD of the delivery date, without a leading zero.
        mm, dd = row[idx["delivery_time"]][:5].split("-")
        assert row[idx["ds"]] == str(int(mm) * 100 + int(dd))
    # A GPS fix is missing as a whole: time, lng and lat together.
    for prefix in ("accept_gps", "delivery_gps"):
        t, g = idx[f"{prefix}_time"], idx[f"{prefix}_lng"]
        assert all((r[t] == "") == (r[g] == "") for r in rows)
        assert 0 < sum(r[t] == "" for r in rows) < 0.1 * len(rows)
    # pyarrow's type inference reads it back with the real export's types.
    schema = pacsv.read_csv(EXAMPLE).schema
    assert schema.field("order_id").type == pa.int64()
    assert schema.field("lng").type == pa.float64()
    assert schema.field("ds").type == pa.int64()
    assert schema.field("delivery_time").type == pa.string()


def test_same_seed_same_bytes(tmp_path: Path) -> None:
    cfg = SynthConfig(days=3, seed=11)
    for suffix in ("csv", "parquet"):
        a = write(generate(cfg), tmp_path / f"a.{suffix}")
        b = write(generate(cfg), tmp_path / f"b.{suffix}")
        assert a.read_bytes() == b.read_bytes()
    c = write(generate(SynthConfig(days=3, seed=12)), tmp_path / "c.csv")
    assert c.read_bytes() != (tmp_path / "a.csv").read_bytes()
    assert pq.read_table(tmp_path / "a.parquet").equals(generate(cfg))
    # Written atomically: nothing but the targets is left in the folder.
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "a.csv", "a.parquet", "b.csv", "b.parquet", "c.csv"
    ]  # fmt: skip


def test_write_rejects_unknown_format(table: pa.Table, tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="expected format"):
        write(table, tmp_path / "x.csv", format="json")  # type: ignore[arg-type]
    assert list(tmp_path.iterdir()) == []


def test_quirks_at_stated_rates(table: pa.Table, lines: list[str]) -> None:
    n = table.num_rows
    lng, lat = _col(table, "lng"), _col(table, "lat")
    empty, zero = np.isnan(lng) & np.isnan(lat), (lng == 0) & (lat == 0)
    assert empty.sum() > 0 and zero.sum() > 0
    assert 0.0015 < (empty | zero).mean() < 0.006  # ~0.3 %
    n_dup = n - len(set(lines[1:]))
    assert 0.003 < n_dup / n < 0.008  # ~0.5 %
    acc = _seconds(_col(table, "accept_time"))
    dlv = _seconds(_col(table, "delivery_time"))
    assert 0.0003 < (dlv < acc).mean() < 0.002  # ~0.1 %


def test_accept_before_delivery(table: pa.Table) -> None:
    ok = _clean(table)
    acc = _seconds(_col(table, "accept_time"))[ok]
    dlv = _seconds(_col(table, "delivery_time"))[ok]
    lead_h = (dlv - acc) / 3600.0
    assert lead_h.min() >= 0.3 and lead_h.max() <= 6.0
    # Early deliveries were accepted the evening before: MM-DD says so.
    prev = acc // 86_400 < dlv // 86_400
    assert prev.sum() > 0
    assert np.all(dlv[prev] // 86_400 - acc[prev] // 86_400 == 1)


@pytest.mark.parametrize("seed", [7, 1])
def test_densest_square_density(seed: int) -> None:
    """The busiest 10 km square gets the paper's 400-600 requests due in 09-17 a day."""
    t = generate(SynthConfig(days=12, seed=seed))
    ok = _clean(t)
    lng, lat = _col(t, "lng")[ok], _col(t, "lat")[ok]
    frame = densest_square(lng, lat, 10.0)
    inside = frame.contains(*frame.to_xy(lng, lat))
    sec = _seconds(_col(t, "delivery_time")[ok]) % 86_400
    due = inside & (sec >= 9 * 3600) & (sec < 17 * 3600)
    ds = _col(t, "ds")[ok]
    per_day = [int(due[ds == d].sum()) for d in np.unique(ds)]
    assert len(per_day) == 12
    assert 400 <= np.mean(per_day) <= 600, per_day
    # The whole city is much larger than the square: very different densities.
    assert inside.mean() < 0.5


def test_daily_shape(table: pa.Table) -> None:
    sec = _seconds(_col(table, "delivery_time")) % 86_400
    hours = np.bincount(sec // 3600, minlength=24)
    night = (hours[:7].sum() + hours[20:].sum()) / hours.sum()
    assert 0 < night < 0.01  # 07:00-20:00 but for a few night drops
    assert hours[10] > 2 * hours[12] and hours[15] > 2 * hours[12]  # two peaks, a midday lull
    outside = 1 - hours[9:17].sum() / hours.sum()
    assert 0.05 < outside < 0.3  # some due outside service hours
    per_day = np.bincount(np.unique(_col(table, "ds"), return_inverse=True)[1])
    assert per_day.std() > 0  # volume varies by day


def test_couriers_and_gps(table: pa.Table) -> None:
    courier, region = _col(table, "courier_id"), _col(table, "region_id")
    pairs = set(zip(courier.tolist(), region.tolist(), strict=True))
    assert len({c for c, _ in pairs}) == len(pairs)  # each courier serves one region
    assert len(np.unique(region)) > 30 and len(np.unique(_col(table, "aoi_id"))) > 300
    ok = _clean(table) & np.isfinite(_col(table, "delivery_gps_lng"))
    dx = (_col(table, "delivery_gps_lng") - _col(table, "lng"))[ok] * 95_000
    dy = (_col(table, "delivery_gps_lat") - _col(table, "lat"))[ok] * 111_000
    assert np.median(np.hypot(dx, dy)) < 100  # the fix is near the customer


def test_config_validated() -> None:
    with pytest.raises(ValidationError):
        SynthConfig(days=0)
    with pytest.raises(ValidationError):
        SynthConfig(duplicate_rate=-0.1)
    with pytest.raises(ValidationError):
        SynthConfig(nonsense=1)  # type: ignore[call-arg]


def test_example_file_is_reproducible(tmp_path: Path) -> None:
    """The shipped example is exactly what the documented call produces."""
    assert EXAMPLE.stat().st_size <= 5_000_000
    again = write(generate(SynthConfig(days=12, seed=7)), tmp_path / "again.csv")
    assert again.read_bytes() == EXAMPLE.read_bytes()
