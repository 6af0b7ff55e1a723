"""Windows on a day the clocks change: elapsed time from service start (docs/decisions.md,
"Study area, windows"), so every window is as long as the others and none starts where
another did."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.config import DataConfig
from marops_cli.data.prepare import prepare_day, study_frame
from marops_cli.data.reader import read_lade

LONDON = DataConfig(
    center=(-0.12, 51.5), service_start="00:00", service_end="06:00", tz="Europe/London"
)
SPRING, AUTUMN = dt.date(2022, 3, 27), dt.date(2022, 10, 30)  # 01:00 -> 02:00; 02:00 -> 01:00


def _london(path: Path) -> Path:
    """Orders due on both clock-change days, and on a day between, in central London."""
    rows = ["order_id,lng,lat,accept_time,delivery_time"]
    due = {
        SPRING: ["00:10", "00:40", "02:10", "02:40", "05:50", "06:10"],
        dt.date(2022, 6, 1): ["00:10", "02:10", "05:50"],
        AUTUMN: ["00:10", "01:10", "01:40", "02:10", "04:50", "05:50"],
    }
    for day, times in due.items():
        for k, hhmm in enumerate(times):
            oid = f"{day:%m%d}-{k}"
            lng = -0.12 + 0.001 * k
            rows.append(f"{oid},{lng:.4f},51.5000,{day} 00:00:00,{day} {hhmm}:00")
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("day", "windows", "outside"),
    [
        # 02:10 BST is 70 minutes after 00:00 GMT: window 2, not 4 (there is no 01:00);
        # six hours of service end at 07:00 BST, so 06:10 is inside.
        (SPRING, {"00:10": 0, "00:40": 1, "02:10": 2, "02:40": 3, "05:50": 9, "06:10": 10}, 0),
        (dt.date(2022, 6, 1), {"00:10": 0, "02:10": 4, "05:50": 11}, 0),
        # 01:10 and 01:40 are the first (BST) ones; 02:10 GMT is 190 minutes after
        # 00:00 BST: window 6; six hours end at 05:00 GMT, so 05:50 is outside.
        (AUTUMN, {"00:10": 0, "01:10": 2, "01:40": 3, "02:10": 6, "04:50": 11}, 1),
    ],
)
def test_windows_are_elapsed_time_from_service_start(
    tmp_path: Path, day: dt.date, windows: dict[str, int], outside: int
) -> None:
    table = read_lade(_london(tmp_path / "london.csv"), LONDON)
    reqs = prepare_day(table, study_frame(table, LONDON, [day]), day, LONDON)
    due = {f"{t:%H:%M}": int(w) for t, w in zip(_wall(table, reqs), reqs.due_w, strict=True)}
    assert due == windows
    assert reqs.outside_hours == outside
    # As instants (aware datetimes of one zone subtract as wall clocks do).
    starts = np.array([reqs.window_instant(w).timestamp() for w in range(reqs.n_windows)])
    np.testing.assert_array_equal(np.diff(starts), 1800.0)


def _wall(table, reqs) -> list[dt.datetime]:
    """The wall-clock due time of each of ``reqs``, from the file."""
    by_id = dict(zip(table.order_id, table.delivery_s, strict=True))
    return [dt.datetime(1970, 1, 1) + dt.timedelta(seconds=int(by_id[o])) for o in reqs.order_id]


def test_route_files_never_start_two_windows_at_one_instant(tmp_path: Path) -> None:
    """With service from 00:00 on the day the clocks go forward, windows 2 and 4 both
    started at 02:00 BST (01:00 does not exist, and read as 01:00 GMT); and on the day
    they go back, windows 4 and 5 were written at 01:00 and 01:30 BST again."""
    data = _london(tmp_path / "london.csv")
    cfg = tmp_path / "london.toml"
    cfg.write_text(
        '[data]\narea = "square"\ncenter = [-0.12, 51.5]\nservice_start = "00:00"\n'
        'service_end = "06:00"\ntz = "Europe/London"\n[segment]\nn_depots = 3\n'
    )
    for day in (SPRING, AUTUMN):
        out = tmp_path / f"{day:%m%d}"
        args = ["replay-day", str(data), "--date", f"{day:%m%d}", "--config", str(cfg)]
        res = CliRunner().invoke(app, [*args, "--method", "greedy", "--out", str(out)])
        assert res.exit_code == 0, res.output
        routes = pq.read_table(out / "routes.parquet")
        first: dict[int, dt.datetime] = {}
        windows, starts_of = routes["window"].to_pylist(), routes["window_start"].to_pylist()
        for w, start in zip(windows, starts_of, strict=True):
            first.setdefault(w, start)
        starts = np.array([first[w].timestamp() for w in sorted(first)])
        np.testing.assert_array_equal(np.diff(starts), 1800.0)
        stops = pq.read_table(out / "stops.parquet")
        arrive = np.array([t.timestamp() for t in stops["arrive_time"].to_pylist()])
        start = np.array([t.timestamp() for t in stops["window_start"].to_pylist()])
        np.testing.assert_array_equal(arrive - start, np.floor(stops["arrive_s"].to_numpy()))


def test_a_time_with_its_offset_in_the_repeated_hour_is_placed_by_its_instant(
    tmp_path: Path,
) -> None:
    """01:10 GMT on the day the clocks go back is 130 minutes after 00:00 BST (window
    4); 01:10 BST, the same wall clock, 70 (window 2). Without an offset 01:10 is the
    first."""
    rows = ["order_id,lng,lat,accept_time,delivery_time"]
    for oid, due in (("gmt", "01:10:00+00:00"), ("bst", "01:10:00+01:00"), ("wall", "01:10:00")):
        rows.append(f"{oid},-0.12,51.5,2022-10-30 00:00:00,2022-10-30 {due}")
    path = tmp_path / "autumn.csv"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    table = read_lade(path, LONDON)
    reqs = prepare_day(table, study_frame(table, LONDON, [AUTUMN]), AUTUMN, LONDON)
    got = dict(zip(reqs.order_id, reqs.due_w.tolist(), strict=True))
    assert got == {"gmt": 4, "bst": 2, "wall": 2}


@pytest.mark.parametrize("tz", ["Asia/Shanghai", "Europe/London"])
def test_elapsed_time_from_service_start_is_wall_clock_time_on_steady_days(tz: str) -> None:
    """On days no clock changes, a row's time from its day's service start is found by
    wall-clock arithmetic alone (no instant per row); it equals the instants' difference,
    and on a day the clock changes the instants are used (an hour apart here)."""
    import types

    from marops_cli.data import prepare
    from marops_cli.data.dates import instants

    days = np.array([19_000, 19_001, 19_002, 19_292], dtype=np.int32)  # 2022-01-08.., 2022-10-27
    day = np.repeat(days, 3)
    wall = day.astype(np.int64) * 86_400 + np.tile([9 * 3600, 12 * 3600, 16 * 3600], 4)
    table = types.SimpleNamespace(delivery_day=day, delivery_s=wall, delivery_at=None)
    cfg = DataConfig(tz=tz)
    start, due = prepare._since_start(table, cfg)
    assert due.tolist() == (instants(wall, tz) - start).tolist()
    assert due[:3].tolist() == [0, 3 * 3600, 7 * 3600]
    changed = np.full(3, 19_295, dtype=np.int32)  # 2022-10-30, London's clocks go back at 02:00
    night = changed.astype(np.int64) * 86_400 + np.array([0, 3600, 3 * 3600])
    table = types.SimpleNamespace(delivery_day=changed, delivery_s=night, delivery_at=None)
    start, due = prepare._since_start(table, DataConfig(tz=tz, service_start="00:00"))
    assert due.tolist() == ([0, 3600, 4 * 3600] if tz == "Europe/London" else [0, 3600, 3 * 3600])
