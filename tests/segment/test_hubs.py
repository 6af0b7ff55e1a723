"""Hubs over a city (docs/method.md §1.1): placing the squares, the hubs file, which
hub an order belongs to, and a city day replayed hub by hub."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.config import DataConfig
from marops_cli.data.frame import Frame, densest_square, hub_squares
from marops_cli.errors import InputError
from marops_cli.segment.hubs import Hub, hub_owner, load_hubs

from .conftest import moved_example

runner = CliRunner()
LNG, LAT = 121.47, 31.23


def _cluster(rng: np.random.Generator, cx_m: float, cy_m: float, n: int, sd: float = 800.0):
    ref = Frame(LNG, LAT, 10.0)
    x = rng.normal(cx_m, sd, n)
    y = rng.normal(cy_m, sd, n)
    return ref.to_lnglat(x, y)


def test_squares_are_disjoint_densest_first_and_the_first_is_the_study_square():
    """Three clusters 20 km apart, of 3000, 2000 and 1000 points: three 5 km squares, one
    on each, in that order, the first exactly densest_square's; a fourth would hold
    nothing, so auto stops at three."""
    rng = np.random.default_rng(0)
    parts = [
        _cluster(rng, 0, 0, 3000),
        _cluster(rng, 20_000, 0, 2000),
        _cluster(rng, 0, 20_000, 1000),
    ]
    lng = np.concatenate([p[0] for p in parts])
    lat = np.concatenate([p[1] for p in parts])
    squares = hub_squares(lng, lat, 5.0, 250.0, None, 0.01)
    assert len(squares) == 3
    assert squares[0][0] == densest_square(lng, lat, 5.0, 250.0)
    held = [n for _, n in squares]
    assert held == sorted(held, reverse=True) and held[0] > 2900 and held[2] > 900
    # Each square sits on its cluster and no point lies in two squares.
    inside = []
    for f, n in squares:
        x, y = f.to_xy(lng, lat)
        inside.append(f.contains(x, y))
        assert abs(int(inside[-1].sum()) - n) <= 0.01 * n  # the grid count, up to edges
    assert not (np.sum(inside, axis=0) > 1).any()
    assert len(hub_squares(lng, lat, 5.0, 250.0, 2)) == 2
    assert len(hub_squares(lng, lat, 5.0, 250.0, None, 0.3)) == 2  # 1000 < 30 % of 6000


def test_an_order_belongs_to_the_first_hub_that_holds_it(points_table):
    """Two overlapping squares: a point in both is the first hub's; outside both is -1."""
    a = Frame(LNG, LAT, 2.0)
    ref = Frame(LNG, LAT, 10.0)
    b_lng, b_lat = ref.to_lnglat(np.array([1500.0]), np.array([0.0]))
    b = Frame(float(b_lng[0]), float(b_lat[0]), 2.0)  # overlaps a on x in [500, 1000]
    table = points_table(*ref.to_lnglat(np.array([0.0, 800.0, 2000.0, 5000.0]), np.zeros(4)))
    owner = hub_owner(table, [Hub(0, a), Hub(1, b)])
    assert owner.tolist() == [0, 0, 1, -1]


def test_a_run_warns_when_many_orders_lie_outside_every_hub(points_table):
    """Orders outside every hub placed (another city) are left out: at 5 % of the day's
    orders and above the run says how many, naming the hubs file as the way to plan
    them; below, nothing."""
    import datetime as dt

    from marops_cli.errors import spelled
    from marops_cli.segment.hubs import outside_warning

    ref = Frame(LNG, LAT, 10.0)
    day = [dt.date(1970, 1, 1)]  # the points' orders are due at time 0
    hub = [Hub(0, Frame(LNG, LAT, 2.0))]
    for n, said in ((21, None), (20, "1 of the 20 orders due (5%) lie outside every hub")):
        x = np.r_[np.zeros(n - 1), 300_000.0]  # one order 300 km east: another city
        table = points_table(*ref.to_lnglat(x, np.zeros(n)))
        warning = outside_warning(table, hub, day, 0.01)
        if said is None:
            assert warning is None
        else:
            assert warning is not None and said in warning
            assert "--hubs" in spelled(warning) and "are left out" in warning


def test_the_outside_warning_says_why_the_orders_lie_outside(points_table):
    """The warning names the cause it can tell: the history days the hubs were placed over
    hold their orders in them, and the day replayed has its orders 40 km away; squares
    left out for too few locations for their depots (--n-depots); else the reach and
    the least share, as set (0.1 %, not rounded to 0 %)."""
    import dataclasses
    import datetime as dt

    from marops_cli.errors import spelled
    from marops_cli.segment.hubs import outside_warning

    ref = Frame(LNG, LAT, 10.0)
    history, day = [dt.date(1970, 1, 1)], [dt.date(1970, 1, 2)]
    hub = [Hub(0, Frame(LNG, LAT, 10.0))]
    x = np.r_[np.zeros(20), np.full(20, 40_000.0)]  # day 2's orders 40 km east
    table = points_table(*ref.to_lnglat(x, np.zeros(40)))
    table = dataclasses.replace(table, delivery_s=np.r_[np.zeros(20), np.full(20, 86_400)])
    moved = outside_warning(table, hub, day, 0.01, history=history)
    assert moved is not None and "20 of the 20 orders due (100%)" in moved
    assert "placed over the history days (1970-01-01), whose orders they hold (100%)" in moved
    assert "--hubs" in spelled(moved) and "--dates" in moved and "150 km" not in moved
    plain = outside_warning(table, hub, day, 0.01)  # no history named: the reach
    assert plain is not None and "150 km" in plain and "at least 1% " in plain
    assert "at least 0.1% " in str(outside_warning(table, hub, day, 0.001))
    both = history + day  # the history days replayed: nothing moved
    few = outside_warning(table, hub, both, 0.01, history=both, unplaced=3, n_depots=16)
    assert few is not None and "3 hubs were not placed" in few and "the 16 a hub's" in few
    assert "--n-depots" in spelled(few) and "150 km" in few


def test_the_outside_warning_tells_sparse_squares_from_another_city(points_table):
    """Orders left out 40 km from the hub, within the 150 km hubs are sought in (a city's
    sparse villages), are no other city: the warning says to lower [data] hub_min_share
    (while above its least, 0.004) or name their squares; 300 km away, another city's
    file. It said 'give another city a file of its own' for both."""
    import datetime as dt

    from marops_cli.segment.hubs import outside_warning

    ref = Frame(LNG, LAT, 10.0)
    day = [dt.date(1970, 1, 1)]
    hub = [Hub(0, Frame(LNG, LAT, 10.0))]
    for far_m, sparse in ((40_000.0, True), (300_000.0, False)):
        x = np.r_[np.zeros(30), np.full(10, far_m)]
        table = points_table(*ref.to_lnglat(x, np.zeros(40)))
        said = str(outside_warning(table, hub, day, 0.01))
        assert "10 of the 40 orders due (25%)" in said
        assert ("another city" not in said) is sparse
        assert ("lower it (to 0.004 at the least)" in said) is sparse
    least = str(
        outside_warning(
            points_table(*ref.to_lnglat(np.r_[np.zeros(30), np.full(10, 40_000.0)], np.zeros(40))),
            hub,
            day,
            0.004,
        )
    )
    assert "lower it" not in least and "name their squares in a hubs file" in least


@pytest.mark.parametrize(
    ("doc", "column", "needle"),
    [
        ({"hubs": []}, "hubs", "list of hubs"),
        ({"hubs": [{"center_lng": 121.4}]}, "hubs[0].center_lat", "needs center_lat"),
        (
            {"hubs": [{"center_lng": 190.0, "center_lat": 31.0}]},
            "hubs[0].center_lng",
            "longitude, a number from -180 to 180, got 190.0",
        ),
        (
            {"hubs": [{"center_lng": 121.4, "center_lat": 31.0, "size_km": 0}]},
            "hubs[0].size_km",
            "(0, 200]",
        ),
        (
            {"hubs": [{"center_lng": 121.4, "center_lat": 31.0, "drones": 1.5}]},
            "hubs[0].drones",
            "whole",
        ),
        ({"hubs": [{"center_lng": "x", "center_lat": 31.0}]}, "hubs[0].center_lng", "number"),
        (
            {"hubs": [{"center_lng": 121.4, "center_lat": 31.0, "foo": 1}]},
            "hubs[0].foo",
            "unknown key 'foo' in a hub (expected some of",
        ),
        # What was taken without a word: a top-level typo, an id the list order overrules
        # (hub-0 held the hub that said id 1), a share that is text.
        (
            {"hubs": [{"center_lng": 121.4, "center_lat": 31.0}], "drone": 4},
            "drone",
            "unknown key 'drone' in a hubs file",
        ),
        (
            {"hubs": [{"id": 1, "center_lng": 121.4, "center_lat": 31.0}]},
            "hubs[0].id",
            "expected 0, the hub's place in the list",
        ),
        (
            {"hubs": [{"center_lng": 121.4, "center_lat": 31.0, "share": "half"}]},
            "hubs[0].share",
            "number",
        ),
    ],
)
def test_bad_hubs_files_name_the_key(tmp_path, doc, column, needle):
    p = tmp_path / "hubs.json"
    p.write_text(json.dumps(doc))
    with pytest.raises(InputError) as err:
        load_hubs(p, DataConfig())
    assert err.value.column == column and needle in err.value.message
    assert err.value.file == str(p)


def test_hand_written_hubs_file_takes_defaults(tmp_path):
    p = tmp_path / "h.json"
    p.write_text(json.dumps([{"center_lng": 121.4, "center_lat": 31.2, "drones": 3}]))
    (h,) = load_hubs(p, DataConfig(size_km=7.0))
    assert (h.id, h.frame.size_km, h.drones, h.orders) == (0, 7.0, 3, 0)


def _ok(args: list[str]) -> None:
    """``marops ARGS -q``, which must succeed."""
    res = runner.invoke(app, [*args, "-q"])
    assert res.exit_code == 0, res.output


@pytest.fixture(scope="module")
def city(example_csv: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """segment --hubs 3 on the history days, then 0811 replayed over the three hubs
    (hub 2 with 4 drones), and the plain run of hub 0's square."""
    d = tmp_path_factory.mktemp("city")
    hubs = d / "hubs.json"
    _ok(["segment", str(example_csv), "--hubs", "3", "--dates", "0801..0810", "--out", str(hubs)])
    doc = json.loads(hubs.read_text())
    doc["hubs"][0]["drones"] = 8  # its own fleet: the plain run's, byte for byte
    doc["hubs"][2]["drones"] = 4
    hubs.write_text(json.dumps(doc))
    out = d / "city"
    _ok(["replay-day", str(example_csv), "--date", "0811", "--hubs", str(hubs), "--out", str(out)])
    h0 = doc["hubs"][0]
    cfg = d / "center.toml"
    cfg.write_text(f"[data]\ncenter = [{h0['center_lng']!r}, {h0['center_lat']!r}]\n")
    plain = d / "plain"
    _ok(
        [
            "replay-day",
            str(example_csv),
            "--date",
            "0811",
            "--config",
            str(cfg),
            "--out",
            str(plain),
        ]
    )
    return {"hubs": hubs, "out": out, "plain": plain}


def test_city_day_covers_the_hubs_once_each(city):
    doc = json.loads(city["hubs"].read_text())
    assert [h["id"] for h in doc["hubs"]] == [0, 1, 2]
    assert sum(h["share"] for h in doc["hubs"]) <= 1.0
    metrics = json.loads((city["out"] / "metrics.json").read_text())
    seen: set[str] = set()
    for h in range(3):
        stops = pq.read_table(city["out"] / f"hub-{h}" / "stops.parquet").to_pydict()
        routes = pq.read_table(city["out"] / f"hub-{h}" / "routes.parquet").to_pydict()
        assert set(stops["hub"]) == {h} and set(routes["hub"]) == {h}
        ids = [o for o, k in zip(stops["order_id"], stops["kind"], strict=True) if k == "customer"]
        assert not seen & set(ids), "an order planned in two hubs"
        seen |= set(ids)
        assert len(set(routes["drone"])) == (4 if h == 2 else 8)
    days = metrics["days"]
    assert [d["hub"] for d in days] == [0, 1, 2]
    c = metrics["city"]
    assert c["planned"] == sum(d["requests"] for d in days)
    assert c["delivered"] == sum(d["delivered"] for d in days) == len(seen)
    # Each hub counts its own orders alone: the city's add up, the rest by reason.
    assert c["orders_due"] == sum(d["orders_due"] for d in days) + c["outside_hubs"]
    assert c["outside_hours"] == sum(d["outside_hours"] for d in days)
    assert all(d["outside_area"] == 0 for d in days)
    assert c["planned"] + c["outside_hubs"] + c["outside_hours"] == c["orders_due"]
    assert [h["orders_due"] for h in c["hubs"]] == [d["orders_due"] for d in days]
    assert [h["drones"] for h in c["hubs"]] == [8, 8, 4] and c["drones"] == 20
    assert c["covered_share"] == pytest.approx(c["planned"] / c["orders_due"], rel=1e-12)
    assert c["delivered_share"] == pytest.approx(c["delivered"] / c["orders_due"], rel=1e-12)
    assert 0 < c["covered_share"] < 1
    left = (city["out"] / "left_out.csv").read_text().splitlines()
    assert left[0] == "day,order_id,row,lng,lat,reason"
    assert len(left) - 1 == c["left_out_orders"] == c["outside_hubs"] + c["outside_hours"]
    reasons = [line.rsplit(",", 1)[1] for line in left[1:]]
    assert reasons.count("outside every hub") == c["outside_hubs"]
    assert not set(ids) & {line.split(",")[1] for line in left[1:]}


def test_a_hub_days_warning_names_its_hub(example_csv, city, tmp_path):
    """Hub-days finish in any order on workers: a day's warning names its hub, as the
    day's status line above it does."""
    doc = json.loads(city["hubs"].read_text())
    doc["hubs"] = [dict(doc["hubs"][0], drones=1)]
    hubs = tmp_path / "hubs.json"
    hubs.write_text(json.dumps(doc))
    args = ["replay-day", str(example_csv), "--date", "0811", "--hubs", str(hubs)]
    res = runner.invoke(app, [*args, "--method", "ops-global", "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    warned = [line for line in res.output.splitlines() if "stayed undelivered" in line]
    assert warned and all(w.startswith("warning: hub 0: 2022-08-11: ") for w in warned), warned


def test_a_city_run_finds_each_orders_hub_once(example_csv, city, tmp_path, monkeypatch):
    """Which hub owns each order is worked out once per run and handed to the fleet
    shares, the hubs' areas and the orders left out, not again by each."""
    from marops_cli.segment import hubs as hubs_module

    calls = []
    owner = hubs_module.hub_owner

    def counted(table, hubs):
        calls.append(len(hubs))
        return owner(table, hubs)

    monkeypatch.setattr(hubs_module, "hub_owner", counted)
    args = ["replay-day", str(example_csv), "--date", "0811", "--hubs", str(city["hubs"])]
    res = runner.invoke(app, [*args, "--method", "stay", "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    assert len(calls) == 1, calls


def test_a_single_hub_writes_the_plain_runs_bytes(city):
    """Hub 0 of the city run is the plain run with its square as the study area: the
    route files are the same bytes, the day's metrics the same bar wall times and the
    orders it leaves to the city (those outside its square)."""
    for name in ("stops.parquet", "routes.parquet"):
        assert (city["out"] / "hub-0" / name).read_bytes() == (city["plain"] / name).read_bytes()
    a = json.loads((city["out"] / "hub-0" / "metrics.json").read_text())
    b = json.loads((city["plain"] / "metrics.json").read_text())
    for doc in (a, b):
        doc["meta"].pop("created", None)
        for day in doc["days"]:
            day.pop("runtime_s")
            day["solver"].pop("solve_s")
    hub, plain = a["days"][0], b["days"][0]
    assert hub["outside_area"] == 0 < plain["outside_area"]
    assert hub["orders_due"] == plain["orders_due"] - plain["outside_area"]
    for k in ("orders_due", "outside_area"):
        a["days"][0].pop(k), b["days"][0].pop(k)
    assert a == b


def test_hubs_refuse_depots_and_bad_counts(example_csv, tmp_path, fails_cleanly):
    hubs = tmp_path / "h.json"
    hubs.write_text(json.dumps({"hubs": [{"center_lng": 121.45, "center_lat": 31.2}]}))
    fails_cleanly(
        [
            "replay-day",
            str(example_csv),
            "--date",
            "0811",
            "--hubs",
            str(hubs),
            "--depots",
            str(hubs),
            "--out",
            str(tmp_path / "o"),
        ],
        tmp_path,
        "--hubs",
    )
    fails_cleanly(
        ["segment", str(example_csv), "--hubs", "zero", "--out", str(tmp_path / "x.json")],
        tmp_path,
        "--hubs",
    )


def test_evaluate_over_hubs_keys_rows_and_pairs_by_hub(example_csv, city, tmp_path):
    """``evaluate --hubs``: a row per hub-day (each hub its own fleet size), the same
    numbers as replay-day gives each hub, and pairs matched on hub and day."""
    out = tmp_path / "ev"
    args = ["evaluate", str(example_csv), "--hubs", str(city["hubs"]), "--dates", "0811"]
    args += ["--methods", "marops,stay", "--against", "stay", "--no-plot", "--out", str(out)]
    res = runner.invoke(app, [*args, "-q"])
    assert res.exit_code == 0, res.output
    rows = pq.read_table(out / "results.parquet").to_pylist()
    assert [(r["method"], r["hub"], r["drones"]) for r in rows] == [
        ("marops", 0, 8),
        ("marops", 1, 8),
        ("marops", 2, 4),
        ("stay", 0, 8),
        ("stay", 1, 8),
        ("stay", 2, 4),
    ]
    replayed = json.loads((city["out"] / "metrics.json").read_text())["days"]
    for r, m in zip(rows[:3], replayed, strict=True):  # replay-day ran marops per hub
        assert (r["hub"], r["delivered"], r["requests"]) == (
            m["hub"],
            m["delivered"],
            m["requests"],
        )
        assert r["objective_j_mj"] == pytest.approx(m["objective_j_mj"], rel=1e-12)
    jobs = sorted(p.parents[2].name for p in (out / "jobs").rglob("*.parquet"))
    assert jobs == ["hub=0", "hub=0", "hub=1", "hub=1", "hub=2", "hub=2"]
    import csv

    paired = list(csv.DictReader((out / "paired.csv").open()))
    assert paired and {(p["method"], p["days"]) for p in paired} == {("marops", "3")}
    # the warning counts the hub-days the differences are over, as the table does
    assert "warning: only 1 day (3 hub-days) back the paired comparison" in res.stderr
    summary = list(csv.DictReader((out / "summary.csv").open()))
    assert [(s["method"], s["n"]) for s in summary] == [("marops", "3"), ("stay", "3")]


def test_depot_load_heatmap_of_a_city_shows_one_hubs_depots():
    """Each hub numbers its own depots: the heatmap of a --drones sweep over hubs is
    drawn for the first hub only, and says so."""
    import pyarrow as pa
    from matplotlib.figure import Figure

    from marops_cli.evaluate.plots import _depot_panel

    results = pa.table(
        {
            "alpha": [0.5] * 4,
            "drones": [4, 8, 4, 8],
            "coverage": [0.25] * 4,
            "depots_n": [16] * 4,
            "method": ["marops"] * 4,
            "hub": [0, 0, 1, 1],
            "depot_load_kg_0": [1.0, 2.0, 100.0, 200.0],
            "depot_load_kg_1": [3.0, 4.0, 300.0, 400.0],
        }
    )
    fig = Figure()
    ax = fig.subplots()
    _depot_panel(fig, ax, results, "drones", "marops", {"alpha": 0.5, "coverage": 0.25})
    assert ax.get_title() == "depot load (kg/day), marops, hub 0"
    assert ax.images[0].get_array().tolist() == [[1.0, 3.0], [2.0, 4.0]]


@pytest.mark.parametrize("command", ["replay-day", "evaluate"])
def test_a_hub_too_sparse_for_its_depots_is_named(example_csv, tmp_path, fails_cleanly, command):
    # Hub 0 holds nothing (skipped); hub 1, a 200 m square around one order of the day,
    # has far fewer history requests than the 16 depots: the line says which hub.
    hubs = tmp_path / "h.json"
    hubs.write_text(
        json.dumps(
            [
                {"center_lng": 0.5, "center_lat": 0.5},
                {"center_lng": 121.342616, "center_lat": 31.135035, "size_km": 0.2},
            ]
        )
    )
    days = ["--date", "0811"] if command == "replay-day" else ["--dates", "0811"]
    args = [command, str(example_csv), *days, "--hubs", str(hubs), "--out", str(tmp_path / "o")]
    if command == "evaluate":
        args += ["--methods", "stay"]
    fails_cleanly(args, tmp_path, "setting segment.n_depots: hub 1: 16 depots asked for")


def test_fewer_hubs_than_asked_for_say_so(example_csv: Path, tmp_path: Path) -> None:
    """A town that fits in one square gives one hub, whatever --hubs asks: the table
    says "1 hub" and a warning says why the others are missing."""
    town = moved_example(
        example_csv, tmp_path / "town.csv", lambda k: (121.47 + 0.0001 * (k % 7), 31.23)
    )
    res = runner.invoke(
        app, ["segment", str(town), "--hubs", "3", "--out", str(tmp_path / "h.json")]
    )
    assert res.exit_code == 0, res.output
    text = " ".join(res.output.split())
    assert "1 hub of 10 km" in text
    assert "warning: --hubs 3: the orders fill only 1 non-overlapping 10 km square" in text
    assert len(json.loads((tmp_path / "h.json").read_text())["hubs"]) == 1


@pytest.mark.parametrize(
    ("extra", "named"),
    [
        (["--center", "121.47,31.23"], "--center"),
        (["--n-depots", "4", "--seed", "1"], "--n-depots, --seed"),
        (["--segmentation", "squares"], "--segmentation"),
    ],
)
def test_options_of_one_study_area_are_refused_with_hubs(
    example_csv: Path, tmp_path: Path, extra: list[str], named: str
) -> None:
    """--hubs places its squares itself and segments each hub's depots by [segment]: an
    option that would be ignored (--center, --n-depots, --seed …) is one line naming
    it, exit 2, nothing written."""
    out = tmp_path / "hubs.json"
    res = runner.invoke(
        app, ["segment", str(example_csv), "--hubs", "2", *extra, "--out", str(out)]
    )
    assert res.exit_code == 2, res.output
    assert f"drop {named} " in " ".join(res.output.split())
    assert not out.exists()


@pytest.mark.parametrize(
    ("extra", "named"),
    [
        ({"center": (121.47, 31.23)}, "center"),
        ({"n_depots": 3, "segmentation": "squares"}, "n_depots, segmentation"),
    ],
)
def test_the_api_refuses_them_too(example_csv: Path, tmp_path: Path, extra, named) -> None:
    """The Python API runs what the command runs: an option segment(hubs=...) would
    ignore is an InputError naming the keyword (it was dropped unread)."""
    from marops_cli import api
    from marops_cli.errors import InputError

    with pytest.raises(InputError, match=f"drop {named} "):
        api.segment(example_csv, dates="0801", hubs="auto", out=tmp_path / "h.json", **extra)
    assert not (tmp_path / "h.json").exists()


def test_cover_squares_reach_the_gap_between_disjoint_ones():
    """Two dense towns 12 km apart and a village in the 2 km gap between their 10 km
    squares: disjoint squares cannot hold the village, covering ones do (overlapping the
    towns' squares, whose orders stay theirs); the count is what each square adds."""
    rng = np.random.default_rng(1)
    ref = Frame(LNG, LAT, 10.0)
    a = ref.to_lnglat(rng.uniform(-5000, 5000, 3000), rng.uniform(-5000, 5000, 3000))
    c = ref.to_lnglat(rng.uniform(7000, 17000, 2000), rng.uniform(-5000, 5000, 2000))
    b = ref.to_lnglat(rng.normal(6000, 150, 200), rng.normal(0, 150, 200))
    lng = np.concatenate([a[0], c[0], b[0]])
    lat = np.concatenate([a[1], c[1], b[1]])

    def held(squares):
        hubs = [Hub(i, f, n) for i, (f, n) in enumerate(squares)]
        table = type("T", (), {"lng": lng, "lat": lat, "__len__": lambda s: len(lng)})()
        return hub_owner(table, hubs)  # type: ignore[arg-type]

    disjoint = hub_squares(lng, lat, 10.0, 250.0, None, 0.01)
    cover = hub_squares(lng, lat, 10.0, 250.0, None, 0.01, cover=True)
    village = slice(5000, None)
    assert (held(disjoint)[village] < 0).mean() > 0.5
    assert (held(cover)[village] >= 0).all()
    assert (held(cover) >= 0).mean() > 0.99  # the grid's cells, not the exact edges
    assert len(cover) == 3 and sum(n for _, n in cover) == len(lng)


def test_a_city_fleet_is_shared_by_demand():
    """One drone each, the rest by largest remainder (hand-checked); ties to the first
    hub; no demand: evenly; fewer drones than hubs refused."""
    from marops_cli.segment.hubs import share_fleet

    # 10 drones, demand 60/30/10: 1 each, 7 by quota 4.2/2.1/0.7 -> 4, 2, 0 + the
    # largest remainder (0.7, hub 2) one more.
    assert share_fleet([60, 30, 10], 10) == [5, 3, 2]
    assert share_fleet([1, 1], 3) == [2, 1]
    assert share_fleet([0, 0, 0], 7) == [3, 2, 2]
    assert share_fleet([5], 1) == [1]
    with pytest.raises(InputError, match="fewer than the city's 3 hubs"):
        share_fleet([1, 2, 3], 2)


def test_the_whole_export_over_hubs(example_csv, tmp_path):
    """--area hubs plans the city: hubs placed over the other days, each with its share
    of drones × hubs by demand; the shares read of all orders due add up, and at least
    nine in ten of the orders due within service hours are planned."""
    out = tmp_path / "city"
    args = ["replay-day", str(example_csv), "--date", "0811", "--area", "hubs"]
    res = runner.invoke(app, [*args, "--method", "stay", "--out", str(out), "--json", "-q"])
    assert res.exit_code == 0, res.output
    c = json.loads(res.stdout)["city"]
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["city"] == c
    hubs = metrics["meta"]["hubs"]
    n = len(hubs)
    assert n >= 2 and [h["id"] for h in hubs] == list(range(n))
    drones = [h["drones"] for h in hubs]
    assert sum(drones) == 8 * n and drones[0] == max(drones) and min(drones) >= 1
    assert [h["drones"] for h in c["hubs"]] == drones
    assert c["planned"] + c["outside_hubs"] + c["outside_hours"] == c["orders_due"]
    assert c["planned"] == sum(h["planned"] for h in c["hubs"]) == metrics["total"]["requests"]
    assert c["orders_due"] == metrics["total"]["orders_due"] + c["outside_hubs"]
    assert c["planned"] >= 0.9 * (c["orders_due"] - c["outside_hours"])
    assert sorted(p.name for p in out.glob("hub-*")) == sorted(f"hub-{i}" for i in range(n))


def test_the_api_plans_the_city_as_the_command_does(example_csv, tmp_path):
    """api.replay_day(area="hubs") returns every hub's rows, the city's coverage as
    metrics.json has it; a second call into the same folder reads the kept hubs back."""
    from marops_cli import api

    with pytest.warns(UserWarning):
        day = api.replay_day(example_csv, "0811", area="hubs", method="stay", out=tmp_path / "c")
    doc = json.loads((tmp_path / "c" / "metrics.json").read_text())
    assert day.city == doc["city"] == day.metrics["city"]
    hubs = sorted(set(day.stops.column("hub").to_pylist()))
    assert hubs == [h["hub"] for h in doc["city"]["hubs"]]
    ids, kinds = day.stops.column("order_id").to_pylist(), day.stops.column("kind").to_pylist()
    delivered = {o for o, k in zip(ids, kinds, strict=True) if k == "customer"}
    assert len(delivered) == doc["city"]["delivered"]
    again = api.replay_day(example_csv, "0811", area="hubs", method="stay", out=tmp_path / "c")
    assert again.city == day.city and again.stops.num_rows == day.stops.num_rows
    with pytest.warns(UserWarning):
        one = api.replay_day(example_csv, "0811", area="square", method="stay")
    assert one.city is None and one.stops.num_rows < day.stops.num_rows


def test_evaluate_over_the_whole_export(example_csv, tmp_path):
    """evaluate --area hubs compares over every hub-day of the hubs replay-day places,
    each hub flying its share of the fleet (of each --drones setting)."""
    out = tmp_path / "ev"
    args = ["evaluate", str(example_csv), "--dates", "0811", "--methods", "stay"]
    res = runner.invoke(app, [*args, "--area", "hubs", "--drones", "4,8", "--out", str(out), "-q"])
    assert res.exit_code == 0, res.output
    rows = pq.read_table(out / "results.parquet").to_pylist()
    day = tmp_path / "day"
    res = runner.invoke(
        app,
        [
            "replay-day",
            str(example_csv),
            "--date",
            "0811",
            "--area",
            "hubs",
            "--method",
            "stay",
            "--out",
            str(day),
            "-q",
        ],
    )
    assert res.exit_code == 0, res.output
    placed = json.loads((day / "metrics.json").read_text())
    n = len(placed["meta"]["hubs"])
    for drones in (4, 8):
        mine = sorted((r for r in rows if r["setting"] == (drones == 8)), key=lambda r: r["hub"])
        assert [r["hub"] for r in mine] == list(range(n))
        assert sum(r["drones"] for r in mine) == drones * n
    eight = sorted((r for r in rows if r["drones"] and r["setting"] == 1), key=lambda r: r["hub"])
    assert [r["drones"] for r in eight] == [h["drones"] for h in placed["meta"]["hubs"]]
    assert [r["requests"] for r in eight] == [h["planned"] for h in placed["city"]["hubs"]]
    # The summary (and its figures) speaks of the settings swept, not of one hub's share.
    with (out / "summary.csv").open() as f:
        assert sorted(int(r["drones"]) for r in csv.DictReader(f)) == [4, 8]
    assert (out / "drones.png").stat().st_size > 0 and (out / "actions.png").stat().st_size > 0


def test_a_split_day_no_hub_plans_is_left_out_and_a_named_one_refused(
    example_csv, tmp_path, fails_cleanly
):
    """Over hubs, as in one square: a day of the test split that no hub has anything due
    on in service hours is left out with a warning; named by --dates, refused."""
    data = tmp_path / "straggler.csv"
    row = "999999,1,Shanghai,7,121.34,31.13,1,2,08-12 23:50:00,,,,08-13 00:20:00,,,,813"
    data.write_text(example_csv.read_text(encoding="utf-8") + row + "\n", encoding="utf-8")
    args = ["evaluate", str(data), "--area", "hubs", "--methods", "stay", "--no-plot"]
    named = [*args, "--dates", "0812,0813", "--out", str(tmp_path / "named")]
    fails_cleanly(named, tmp_path, "no requests on 2022-08-13 inside any hub's square")
    res = runner.invoke(app, [*args, "--workers", "1", "--out", str(tmp_path / "split")])
    assert res.exit_code == 0, res.output
    assert (
        "warning: left out 2022-08-13 of the test split: nothing due inside any hub" in res.output
    )
    days = {
        str(d)
        for d in pq.read_table(tmp_path / "split" / "results.parquet").column("day").to_pylist()
    }
    assert days == {"2022-08-11", "2022-08-12"}


def test_a_named_day_the_export_lacks_is_refused_as_replay_day_refuses_it(
    example_csv, tmp_path, fails_cleanly
):
    """evaluate over hubs (the default) given --dates with a day the export has no row
    of (a day missing inside it) names that day and the file's days, as replay-day
    does, before any hub is segmented; it said there were no requests inside any hub's
    square, as if the hubs had left the day's orders out."""
    data = tmp_path / "gap.csv"
    lines = example_csv.read_text(encoding="utf-8").splitlines(keepends=True)
    data.write_text("".join(x for x in lines if not x.rstrip().endswith(",810")), "utf-8")
    args = ["evaluate", str(data), "--methods", "stay", "--no-plot", "--dates", "0809..0811"]
    fails_cleanly(
        [*args, "--out", str(tmp_path / "ev")],
        tmp_path,
        "date 2022-08-10 not in the file (it has 2022-08-01..2022-08-09, 2022-08-11..2022-08-12",
    )


def test_the_whole_export_places_no_hub_too_sparse_for_its_depots(example_csv):
    """A hub that would own fewer history orders than its depots need is not placed
    (its orders fall to the hubs left or outside every hub); none left is refused."""
    from marops_cli.app.inputs import read_data
    from marops_cli.config import PlannerConfig
    from marops_cli.segment.hubs import hub_demand, place_hubs

    cfg = PlannerConfig()
    table = read_data(example_csv, cfg.data)
    history = [d for d in table.days() if d.isoformat() != "2022-08-11"]
    every, _ = place_hubs(table, cfg, history, 16)
    few, unplaced = place_hubs(table, cfg, history, 400)
    assert 1 <= len(few) < len(every) and unplaced >= len(every) - len(few)
    assert [h.id for h in few] == list(range(len(few)))
    assert min(hub_demand(table, few, history)) >= 400
    with pytest.raises(InputError, match="no hub placed over the history days holds"):
        place_hubs(table, cfg, history, 10**6)


def test_a_hub_of_rounded_coordinates_too_few_for_its_depots_is_not_placed(points_table):
    """An export of coordinates rounded to 2 decimals (about 1 km) puts a town's 300
    orders on 5 points: its hub holds enough orders for 16 depots but not the 16 distinct
    locations k-means needs, so it is left out, not placed to fail the whole run; a
    city of one building is refused naming the locations, not the orders."""
    from marops_cli.config import PlannerConfig
    from marops_cli.segment.hubmap import hub_depots
    from marops_cli.segment.hubs import hub_demand, hub_locations, place_hubs

    rng = np.random.default_rng(3)
    town_lng, town_lat = _cluster(rng, 0, 0, 2000)
    spots = np.round(_cluster(rng, 25_000, 0, 5, sd=300.0), 2)
    pick = rng.integers(0, 5, 300)
    lng = np.concatenate([town_lng, spots[0][pick]])
    lat = np.concatenate([town_lat, spots[1][pick]])
    table = points_table(lng, lat)
    cfg = PlannerConfig()
    history = table.days()
    hubs, unplaced = place_hubs(table, cfg, history, 16)
    assert len(hubs) == 1 and unplaced == 1
    assert hub_demand(table, hubs, history) == [2000]
    assert hub_locations(table, hubs, history) == [2000]
    _, why = hub_depots(table, cfg, hubs, history)
    assert why == {}
    one = points_table(np.full(500, LNG), np.full(500, LAT))
    with pytest.raises(InputError, match="16 distinct customer locations .* most any holds is 1"):
        place_hubs(one, cfg, one.days(), 16)


def test_the_city_line_names_the_hubs_and_the_fleet() -> None:
    from marops_cli.app.replay_hubs import city_line

    city = {"drones": 1, "orders_due": 200, "planned": 150, "delivered": 120, "outside_hubs": 50}
    assert city_line(city, 1) == (
        "city: 150 of 200 orders due planned in 1 hub (75.0 %), 120 delivered (60.0 %) "
        "by 1 drone; left out: 50 outside every hub"
    )
    assert "in 12 hubs (75.0 %), 120 delivered (60.0 %) by 96 drones;" in city_line(
        {**city, "drones": 96}, 12
    )


@pytest.mark.parametrize(("size_km", "lat"), [(3.1, LAT), (10.0, 84.0)])
def test_a_hubs_count_is_the_orders_it_owns(points_table, size_km, lat):
    """A square whose side is no whole number of grid steps (3.1 km on a 250 m grid: 12
    cells hold 3 km or 13 hold 3.25) or far north, where the grid's plane and the
    square's part: each hub's count, as the hubs file and the table give it, is the
    orders that hub plans (:func:`hub_owner`), not the grid's count of its cells."""
    from marops_cli.segment.hubs import find_hubs

    rng = np.random.default_rng(5)
    ref = Frame(LNG, lat, 10.0)
    table = points_table(*ref.to_lnglat(rng.uniform(-9e3, 9e3, 4000), rng.uniform(-9e3, 9e3, 4000)))
    cfg = DataConfig(size_km=size_km)
    hubs, total = find_hubs(table, cfg, None, 4)
    owner = hub_owner(table, hubs)
    assert total == 4000 and len(hubs) == 4
    assert [h.orders for h in hubs] == np.bincount(owner[owner >= 0], minlength=4).tolist()
    assert all(h.orders > 0 for h in hubs)


def test_a_day_no_hub_plans_is_refused_before_any_work(example_csv, tmp_path, fails_cleanly):
    """A named day whose orders all lie outside every hub (a hubs file of a square 50 km
    away, or hubs placed over history days whose orders lie elsewhere) planned nothing
    and exited 0, writing empty results; it is refused, as one square's run refuses a
    day with nothing to plan, naming the day, and nothing is written."""
    hubs = tmp_path / "far.json"
    hubs.write_text(json.dumps({"hubs": [{"center_lng": 122.0, "center_lat": 31.6}]}))
    args = ["replay-day", str(example_csv), "--date", "0811", "--hubs", str(hubs)]
    fails_cleanly(
        [*args, "--method", "stay", "--out", str(tmp_path / "o")],
        tmp_path,
        "no requests on 2022-08-11 inside any hub's square due within service hours",
    )


def test_a_day_no_hub_plans_for_its_hours_says_so(example_csv, tmp_path, fails_cleanly):
    """A named day whose orders in the hubs' squares are all due outside service hours
    is refused saying so; before, the error gave no reason, or the run's warning of
    orders outside every hub where there was one, which was not this day's."""
    lines = example_csv.read_text(encoding="utf-8").splitlines(keepends=True)
    late = [
        ",".join(
            [f"9{f[0]}", *f[1:8], "08-13 08:00:00", *f[9:12], "08-13 18:30:00", *f[13:16], "813"]
        )
        + "\n"
        for f in (line.split(",") for line in lines[1:])
        if f[12].startswith("08-11")
    ]
    data = tmp_path / "late.csv"
    data.write_text("".join(lines + late), encoding="utf-8")
    args = ["replay-day", str(data), "--dates", "0812,0813", "--method", "stay"]
    out = [*args, "--out", str(tmp_path / "o")]
    msg = fails_cleanly(out, tmp_path, "no requests on 2022-08-13")
    assert "orders inside a hub's square are all due outside 09:00-17:00" in msg, msg
    assert "outside every hub" not in msg, msg


def test_hubs_placed_by_share_stay_within_the_hub_cap() -> None:
    """Each hub the whole export places adds at least ``[data] hub_min_share`` of the
    orders, so the least share allowed places at most MAX_HUBS hubs (0.001 placed 404
    over a 290 km square of scattered orders, past the cap a hubs file is held to)."""
    from pydantic import ValidationError

    from marops_cli.segment.hubs import MAX_HUBS

    least = 0.004
    assert 1 / least <= MAX_HUBS
    DataConfig(hub_min_share=least)
    with pytest.raises(ValidationError):
        DataConfig(hub_min_share=least / 2)


def _shifted_export(path: Path, shift_h: int) -> Path:
    """Two days of 160 orders in one town, accepted 09:00-16:00 less ``shift_h`` hours
    (times of a zone ``shift_h`` hours behind LaDe's) and due 30 minutes later."""
    rng = np.random.default_rng(3)
    rows = ["order_id,lng,lat,accept_time,delivery_time,ds"]
    for day in (1, 2):
        for k in range(160):
            lng, lat = 121.47 + rng.normal(0, 0.01), 31.23 + rng.normal(0, 0.01)
            accept = 9 * 60 + int(rng.integers(0, 420)) - 60 * shift_h
            due = accept + 30
            rows.append(
                f"{day}{k:04d},{lng:.6f},{lat:.6f},08-0{day} {accept // 60:02d}:"
                f"{accept % 60:02d}:00,08-0{day} {due // 60:02d}:{due % 60:02d}:00,80{day}"
            )
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize("area", ["hubs", "square"])
def test_a_day_mostly_due_outside_service_hours_is_warned_of(tmp_path, area):
    """An export whose times are of another zone (6 hours before LaDe's clock) has most
    orders due outside 09:00-17:00: replay-day over the whole export, or one square,
    warns how many it leaves out for it, between which clock times the orders fall, and
    what to set; only the city line's figures (a square's: none) said so. LaDe's own
    clock: no such warning."""
    for shift_h, warned in ((6, True), (0, False)):
        data = _shifted_export(tmp_path / f"shift{shift_h}.csv", shift_h)
        args = ["replay-day", str(data), "--date", "0802", "--method", "stay", "--workers", "1"]
        args += ["--area", area, "--out", str(tmp_path / f"o{shift_h}"), "-q"]
        res = runner.invoke(app, args)
        assert res.exit_code == 0, res.output
        said = "are due outside service hours 09:00-17:00, and are left out"
        assert (said in res.output) is warned, res.output
        if warned:
            assert "the middle half of all is due between 05:" in " ".join(res.output.split())
            assert "of another zone than Asia/Shanghai" in " ".join(res.output.split())


def test_evaluate_says_why_a_named_day_has_nothing_to_plan(example_csv, tmp_path, fails_cleanly):
    """evaluate --dates over hubs names why a day has nothing to plan, as replay-day
    does: its one order inside a hub's square is due outside service hours (an export
    of another zone's clock has whole days so); it said only that there were none."""
    data = tmp_path / "straggler.csv"
    row = "999999,1,Shanghai,7,121.34,31.13,1,2,08-12 23:50:00,,,,08-13 00:20:00,,,,813"
    data.write_text(example_csv.read_text(encoding="utf-8") + row + "\n", encoding="utf-8")
    for command in ("evaluate", "replay-day"):
        args = [command, str(data), "--dates", "0812,0813", "--out", str(tmp_path / command)]
        fails_cleanly(
            args,
            tmp_path,
            "no requests on 2022-08-13 inside any hub's square due within service hours: "
            "its one order inside a hub's square is due outside 09:00-17:00",
        )


def test_evaluate_warns_of_days_mostly_due_outside_service_hours(tmp_path):
    """evaluate over hubs warns as replay-day does of days whose orders are mostly due
    outside service hours (times of another zone); it compared methods on a fifth of
    the day with nothing said."""
    data = _shifted_export(tmp_path / "shift6.csv", 6)
    args = ["evaluate", str(data), "--dates", "0802", "--methods", "stay", "--no-plot"]
    res = runner.invoke(app, [*args, "--workers", "1", "--out", str(tmp_path / "ev"), "-q"])
    assert res.exit_code == 0, res.output
    said = " ".join(res.output.split())
    assert "are due outside service hours 09:00-17:00, and are left out" in said, said
