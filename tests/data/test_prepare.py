"""Study area, windows and weights on a hand-checkable day."""

from __future__ import annotations

import datetime as dt
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from marops_cli.config import DataConfig
from marops_cli.data.frame import Frame
from marops_cli.data.prepare import parcel_weights, prepare_day, prepare_days, study_frame
from marops_cli.data.reader import read_lade
from marops_cli.data.table import LADE_COLUMNS
from marops_cli.errors import InputError

DAY = dt.date(2022, 8, 20)
CENTER = (121.47, 31.23)
CFG = DataConfig(center=CENTER)  # 09:00-17:00, 16 windows of 30 min, 10 km square

# (order_id, lng, lat, accept, delivery, expected visible_w, expected due_w)
REQUESTS = [
    ("A", 121.470, 31.230, "08-20 08:00:00", "08-20 09:10:00", 0, 0),  # accepted before 9:00
    ("B", 121.480, 31.235, "08-20 10:05:00", "08-20 11:40:00", 2, 5),
    ("C", 121.460, 31.225, "08-19 20:00:00", "08-20 16:59:59", 0, 15),  # accepted the day before
    ("D", 121.471, 31.231, "08-20 12:29:59", "08-20 12:30:00", 6, 7),  # window edges
    ("E", 121.472, 31.229, "08-20 09:00:00", "08-20 11:40:00", 0, 5),  # ties B on due time
]
LEFT_OUT = [
    ("F", 121.470, 31.230, "08-20 08:00:00", "08-20 17:00:00"),  # due at closing: outside
    ("G", 121.470, 31.230, "08-20 07:00:00", "08-20 08:59:59"),  # due before opening
    ("H", 121.700, 31.230, "08-20 09:00:00", "08-20 10:00:00"),  # ~22 km east: outside square
    ("I", 121.470, 31.230, "08-21 09:00:00", "08-21 10:00:00"),  # another day
]


def write_day(path: Path, rows, extra: dict[str, list[str]] | None = None) -> Path:
    cols = list(LADE_COLUMNS) + list(extra or {})
    lines = [",".join(cols)]
    for k, (oid, lng, lat, acc, dlv, *_) in enumerate(rows):
        r = dict.fromkeys(cols, "1")
        r.update(
            order_id=oid,
            lng=str(lng),
            lat=str(lat),
            accept_time=acc,
            delivery_time=dlv,
            ds=dlv[:5].replace("-", "").lstrip("0"),
        )
        for name, values in (extra or {}).items():
            r[name] = values[k]
        lines.append(",".join(r[c] for c in cols))
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture()
def table(tmp_path: Path):
    return read_lade(write_day(tmp_path / "day.csv", REQUESTS + LEFT_OUT), CFG)


def test_windows_hand_checked(table) -> None:
    day = prepare_day(table, study_frame(table, CFG), DAY, CFG)
    # Sorted by due time, then order id: A, B, E, D, C.
    assert list(day.order_id) == ["A", "B", "E", "D", "C"]
    expect = {r[0]: r for r in REQUESTS}
    np.testing.assert_array_equal(day.visible_w, [expect[o][5] for o in day.order_id])
    np.testing.assert_array_equal(day.due_w, [expect[o][6] for o in day.order_id])
    assert day.visible_w.dtype == np.int32 and day.due_w.dtype == np.int32
    # Seconds from 09:00: A due 09:10 -> 600; C accepted 13 h before opening.
    np.testing.assert_allclose(day.due_s, [600, 9600, 9600, 12600, 28799], rtol=0, atol=0)
    np.testing.assert_allclose(day.accept_s[[0, 4]], [-3600, -13 * 3600], rtol=0, atol=0)
    assert (day.n_windows, day.window_s, day.service_start_s) == (16, 1800.0, 9 * 3600)
    assert day.window_start(2) == dt.datetime(2022, 8, 20, 10, 0)
    # A sits at the centre; B 0.01 deg east and 0.005 deg north:
    # x = R cos(31.23 deg) * 0.01 * pi/180, y = R * 0.005 * pi/180 with R = 6371008.8 m.
    np.testing.assert_allclose([day.x_m[0], day.y_m[0]], [0, 0], atol=1e-6)
    np.testing.assert_allclose([day.x_m[1], day.y_m[1]], [950.82, 555.98], rtol=1e-5)
    np.testing.assert_allclose(day.lng[1], 121.48, rtol=0, atol=1e-12)
    assert (day.visible_w <= day.due_w).all()


def test_paper_window_count(table) -> None:
    cfg = DataConfig(center=CENTER, windows=12)  # 40-minute windows
    day = prepare_day(table, study_frame(table, cfg), DAY, cfg)
    by_id = dict(zip(day.order_id, day.due_w, strict=True))
    # 09:10 -> 0; 11:40 -> 160 min -> 4; 12:30 -> 210 min -> 5; 16:59:59 -> 11
    assert by_id == {"A": 0, "B": 4, "E": 4, "D": 5, "C": 11}


def test_weights_from_hash_or_file(tmp_path: Path, table) -> None:
    frame = study_frame(table, CFG)
    day = prepare_day(table, frame, DAY, CFG)
    np.testing.assert_allclose(day.weight_kg, parcel_weights(day.order_id, CFG), rtol=0, atol=0)
    rows = REQUESTS + LEFT_OUT
    weights = [f"{0.1 * (k + 1):.1f}" for k in range(len(rows))]
    t = read_lade(write_day(tmp_path / "w.csv", rows, {"weight_kg": weights}), CFG)
    day = prepare_day(t, frame, DAY, CFG)
    np.testing.assert_allclose(day.weight_kg, [0.1, 0.2, 0.5, 0.4, 0.3], rtol=1e-12)


def test_a_date_without_its_year_names_the_files_day_of_another_year(tmp_path: Path) -> None:
    """An export over the new year with full dates: ``--date 0101`` takes the default year
    (2022-01-01), which the file has not; the error names the file's 1 January
    (2023-01-01) to give in full."""
    from marops_cli.data.prepare import check_days_in_file

    path = tmp_path / "ny.csv"
    path.write_text(
        "order_id,lng,lat,accept_time,delivery_time\n"
        "1,121.47,31.23,2022-12-31 08:00:00,2022-12-31 10:00:00\n"
        "2,121.48,31.24,2022-12-31 21:00:00,2023-01-01 10:00:00\n"
    )
    table = read_lade(path, DataConfig())
    with pytest.raises(InputError) as err:
        check_days_in_file(table, [dt.date(2022, 1, 1)])
    assert (
        "date 2022-01-01 not in the file (it has 2022-12-31..2023-01-01; its 01-01 is "
        "2023-01-01: give the date in full)" in str(err.value)
    )


def test_date_not_in_file(table) -> None:
    with pytest.raises(InputError) as err:
        prepare_day(table, study_frame(table, CFG), dt.date(2022, 8, 22), CFG)
    msg = str(err.value)
    assert "day.csv" in msg
    assert "date 2022-08-22 not in the file (it has 2022-08-20..2022-08-21)" in msg
    with pytest.raises(InputError, match="2022-09-01 not in the file"):
        study_frame(table, DataConfig(), [dt.date(2022, 9, 1)])


def test_a_date_in_a_gap_of_the_file_names_the_days_around_it(tmp_path: Path) -> None:
    """A day missing among many (an export of 2 orders a day with days off): the list of
    the file's days stops at its first runs, so the error names the days around it."""
    from marops_cli.data.prepare import check_days_in_file

    days = [dt.date(2022, 5, 1) + dt.timedelta(days=k) for k in range(60) if k % 7 != 6]
    rows = [f"{k},121.47,31.23,{d:%m-%d} 08:00:00,{d:%m-%d} 10:00:00" for k, d in enumerate(days)]
    path = tmp_path / "gaps.csv"
    path.write_text("order_id,lng,lat,accept_time,delivery_time\n" + "\n".join(rows) + "\n")
    table = read_lade(path, DataConfig())
    with pytest.raises(InputError) as err:
        check_days_in_file(table, [dt.date(2022, 6, 18)])
    assert "and 16 more days; the nearest days it has are 2022-06-17 and 2022-06-19)" in str(
        err.value
    )


def test_empty_study_area(table) -> None:
    far = Frame(100.0, 20.0, 10.0)
    with pytest.raises(InputError) as err:
        prepare_day(table, far, DAY, CFG)
    msg = str(err.value)
    assert "day.csv" in msg and "no requests on 2022-08-20 inside the study area" in msg


def test_study_frame_center_or_densest(table) -> None:
    assert study_frame(table, CFG) == Frame(CENTER[0], CENTER[1], 10.0)
    dense = study_frame(table, DataConfig(size_km=2.0), [DAY])
    x, y = dense.to_xy(np.array([121.47]), np.array([31.23]))
    assert dense.contains(x, y)[0]  # the cluster of A, B, D, E, not the stray H
    assert study_frame(table, DataConfig(size_km=2.0), [DAY]) == dense  # reproducible


def test_prepare_days(table) -> None:
    frame, days = prepare_days(table, [DAY, dt.date(2022, 8, 21)], CFG)
    assert frame == Frame(CENTER[0], CENTER[1], 10.0)
    assert [len(d) for d in days] == [5, 1]
    assert list(days[1].order_id) == ["I"]


def test_parcel_weights_deterministic_and_bounded() -> None:
    ids = np.array([str(10_000_000 + k) for k in range(20_000)], dtype=object)
    w = parcel_weights(ids, DataConfig())
    np.testing.assert_array_equal(w, parcel_weights(ids.copy(), DataConfig()))
    assert w.min() >= 0.1 and w.max() <= 2.5
    # Median of 20k lognormal draws: standard error ~0.5 %, so 3 % is a loose bound.
    np.testing.assert_allclose(np.median(w), 0.5, rtol=0.03)
    inner = w[(w > 0.1) & (w < 2.5)]
    assert 0.5 < np.std(np.log(inner)) < 0.62  # sigma 0.6, a little less after clipping
    # Each id on its own gets the same weight as in the batch.
    assert parcel_weights(ids[5:6], DataConfig())[0] == w[5]
    cfg = DataConfig(weight_median_kg=1.0, weight_sigma=0.0)
    np.testing.assert_allclose(parcel_weights(ids[:10], cfg), 1.0, rtol=1e-12)


def test_parcel_weights_same_in_another_process() -> None:
    code = (
        "from marops_cli.config import DataConfig;"
        "from marops_cli.data.prepare import parcel_weights;"
        "print(repr(parcel_weights(['1001', '1002', 'A'], DataConfig())[:].tolist()))"
    )
    env = dict(os.environ, PYTHONHASHSEED="12345")
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env=env,
        cwd=Path(__file__).resolve().parents[2],
    )
    here = parcel_weights(np.array(["1001", "1002", "A"], dtype=object), DataConfig())
    assert eval(out.stdout) == here.tolist()  # noqa: S307 - our own repr of floats


def test_parcel_weights_accepts_ints_as_text() -> None:
    cfg = DataConfig()
    np.testing.assert_array_equal(
        parcel_weights([1001, 1002], cfg), parcel_weights(["1001", "1002"], cfg)
    )


def test_left_out_orders_add_up_to_the_files_rows(example_csv):
    """Every row of the file is accounted for: dropped as bad, or due on a day and then
    planned, outside the study area or outside service hours."""
    from marops_cli.config import DataConfig
    from marops_cli.data.prepare import prepare_day, study_frame
    from marops_cli.data.reader import read_lade

    cfg = DataConfig(size_km=4.0)  # a small square, so the area leaves many out
    table = read_lade(example_csv, cfg)
    frame = study_frame(table, cfg, table.days())
    counted, area, hours = 0, 0, 0
    for day in table.days():
        reqs = prepare_day(table, frame, day, cfg)
        assert reqs.orders_due == len(reqs) + reqs.outside_area + reqs.outside_hours
        counted += reqs.orders_due
        area += reqs.outside_area
        hours += reqs.outside_hours
    assert counted + table.report.n_dropped == table.report.total
    assert area > 0 and hours > 0
