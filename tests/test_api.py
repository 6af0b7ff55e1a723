"""The Python API runs the commands: the same files, the tables read back, raised errors."""

from __future__ import annotations

import datetime as dt
import json
import os
from pathlib import Path

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

import marops_cli.segment  # noqa: F401  (a subpackage must not shadow the API's segment)
from marops_cli import api as marops
from marops_cli.cli.app import app
from marops_cli.errors import InputError


def test_api_runs_what_the_cli_runs(example_csv: Path, tmp_path: Path, capsys) -> None:
    rows = marops.read_lade(example_csv)
    report = json.loads(rows.schema.metadata[b"marops"])["drop_report"]
    assert rows.num_rows == report["kept"] and report["total"] == report["kept"] + sum(
        report["dropped"].values()
    )
    depots = marops.segment(example_csv, out=tmp_path / "depots.json", dates="0801..0810")
    assert len(depots["depots"]) == 16 and (tmp_path / "depots.json").is_file()

    day = marops.replay_day(
        example_csv, "0811", out=tmp_path / "api", depots=tmp_path / "depots.json", method="stay"
    )
    res = CliRunner().invoke(
        app,
        ["replay-day", str(example_csv), "--date", "0811", "--method", "stay"]
        + ["--depots", str(tmp_path / "depots.json"), "--out", str(tmp_path / "cli")],
    )
    assert res.exit_code == 0, res.output
    for name in ("stops.parquet", "routes.parquet"):  # byte for byte the CLI's files
        assert (tmp_path / "api" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()
    cli_metrics = json.loads((tmp_path / "cli" / "metrics.json").read_text())["days"][0]
    timing = ("runtime_s", "solver")  # wall times differ run to run
    assert {k: v for k, v in day.metrics.items() if k not in timing} == {
        k: v for k, v in cli_metrics.items() if k not in timing
    }
    # Parquet stores seconds as milliseconds: the file's table read back is the same rows
    # in the unit of the tables' schema (docs/outputs.md), less the file's GeoParquet
    # geometry and its metadata.
    from_file = pq.read_table(tmp_path / "cli" / "routes.parquet")
    assert day.routes.equals(from_file.drop_columns(["geometry"]).cast(day.routes.schema))
    file_meta = dict(from_file.schema.metadata)
    assert file_meta.pop(b"geo") and day.routes.schema.metadata == file_meta
    assert day.folder == tmp_path / "api"
    # The same call again keeps the day written: the same tables, in the same units.
    again = marops.replay_day(
        example_csv, "0811", out=tmp_path / "api", depots=tmp_path / "depots.json", method="stay"
    )
    for kept, made in ((again.stops, day.stops), (again.routes, day.routes)):
        assert kept.schema.equals(made.schema, check_metadata=True) and kept.equals(made)
    # A kept day's file edited to times of a fraction of a second (no marops file holds
    # one): one InputError naming it, not pyarrow's ArrowInvalid.
    routes = tmp_path / "api" / "routes.parquet"
    table = pq.read_table(routes)
    k = next(i for i, f in enumerate(table.schema) if pa.types.is_timestamp(f.type))
    col = pc.add(table.column(k), pa.scalar(500, pa.duration("ms")))
    pq.write_table(table.set_column(k, table.schema.field(k), col), routes)
    with pytest.raises(InputError, match=r"routes\.parquet"):
        marops.replay_day(
            example_csv,
            "0811",
            out=tmp_path / "api",
            depots=tmp_path / "depots.json",
            method="stay",
        )
    # pandas reads the stops' nullable integers as integers, from the file and in memory
    # (docs/outputs.md, "Integers"); a column without a missing value stays int32.
    pd = pytest.importorskip("pandas")
    for stops in (pd.read_parquet(tmp_path / "cli" / "stops.parquet"), day.stops.to_pandas()):
        assert str(stops["depot"].dtype) == "Int32" and str(stops["due_window"].dtype) == "Int32"
        assert stops["depot"].isna().any() and stops["due_window"].isna().any()
        assert str(stops["window"].dtype) == "int32" and str(stops["seq"].dtype) == "int32"

    window = marops.plan_window(example_csv, tmp_path / "depots.json", "0811", 5)
    assert window.folder is None  # a temporary folder, gone
    assert set(window.routes.column("window").to_pylist()) == {5}
    assert window.metrics["objective"]["G"] > 0
    # The window's objective is in joules, its energy the routes' (DayResult.metrics).
    score = window.metrics["objective"]
    assert score["energy_j"] == pytest.approx(pc.sum(window.routes.column("energy_j")).as_py())
    assert score["served"] == pc.sum(window.routes.column("n_parcels")).as_py()
    assert score["J"] > score["energy_j"] > 1e5  # joules, not MJ
    captured = capsys.readouterr()
    assert captured.out == ""  # nothing printed by the API


def test_read_lade_times_carry_their_zone(example_csv: Path) -> None:
    import pyarrow as pa

    rows = marops.read_lade(example_csv)
    for name in ("accept_time", "delivery_time"):
        assert rows.schema.field(name).type == pa.timestamp("s", tz="Asia/Shanghai")
    first = rows.slice(0, 1).to_pylist()[0]  # the file's first row: 08-01 07:20:15 local
    assert first["accept_time"].isoformat() == "2022-08-01T07:20:15+08:00"
    # The zone-aware rows read back as the same rows (the reader takes zone-aware times).
    keep = ["order_id", "lng", "lat", "accept_time", "delivery_time"]
    again = marops.read_lade(rows.select(keep))
    assert again.column("accept_time").equals(rows.column("accept_time"))
    assert again.column("delivery_time").equals(rows.column("delivery_time"))
    utc = marops.read_lade(example_csv, tz="UTC").slice(0, 1).to_pylist()[0]
    assert utc["accept_time"].isoformat() == "2022-08-01T07:20:15+00:00"


def test_api_raises_input_errors(example_csv: Path, tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not in the file|no requests|0101"):
        marops.replay_day(example_csv, "0101", out=tmp_path / "x")
    with pytest.raises(InputError, match="file not found"):
        marops.replay_day(tmp_path / "missing.csv", "0811")


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda d: marops.read_lade(d, tz="Nope/Zone"), r"read_lade\(\): tz: unknown time zone"),
        (lambda d: marops.read_lade(d, year=[2022]), r"read_lade\(\): year expects an integer"),
        (lambda d: marops.segment(d, out=5), r"segment\(\): out expects a path, got int 5"),
        (lambda d: marops.segment(d, center=(1,)), r"center expects a \(lng, lat\) pair"),
        (lambda d: marops.segment(d, dates={"0801"}), r"dates expects a string like 'a,b'"),
        (
            lambda d: marops.plan_window(d, 5, "0811", 5),
            r"depots expects a path or the depots segment\(\) returns, got int 5",
        ),
        (lambda d: marops.plan_window(d, "x.json", "0811", "x"), r"window expects an integer"),
        (lambda d: marops.replay_day(d, 8.11), r"date expects a date like '0820'"),
        (lambda d: marops.replay_day(d, "0811", drones=2.5), r"drones expects an integer"),
        (lambda d: marops.replay_day(d, "0811", strict="yes"), r"strict expects True or False"),
        (lambda d: marops.evaluate(d, nonsense=1), r"evaluate\(\): got an unexpected keyword"),
        (lambda d: marops.replay_day(d, "0811", methd="x"), r"'methd' \(did you mean method\?\)$"),
        (lambda d: marops.report(5), r"report\(\): folder expects a path"),
    ],
)
def test_api_wrong_argument_types_name_the_keyword(example_csv: Path, call, message) -> None:
    # A wrong type is bad input like a bad flag: one InputError naming the keyword.
    with pytest.raises(InputError, match=message) as err:
        call(example_csv)
    assert "\n" not in str(err.value)


def test_api_takes_numpy_true_or_false_where_a_flag_is_on_or_off(
    example_csv: Path, tmp_path: Path
) -> None:
    # A frame's .any() or a comparison gives numpy's True or False: a switch takes it as
    # Python's, where it was refused as "expects True or False, got bool np.True_".
    np = pytest.importorskip("numpy")
    bad = tmp_path / "bad.csv"
    lines = example_csv.read_text().splitlines()[:4]
    lines[3] = lines[3].replace(",121.", ",x121.", 1)  # lng not a number
    bad.write_text("\n".join(lines) + "\n")
    assert marops.read_lade(bad, strict=np.False_).equals(marops.read_lade(bad, strict=False))
    with pytest.raises(InputError, match=r"bad\.csv.*row 4"):
        marops.read_lade(bad, strict=np.True_)
    with pytest.raises(InputError, match=r"drones expects an integer, got bool"):
        marops.replay_day(example_csv, "0811", drones=np.True_)


def test_api_takes_lists_and_dates_where_the_flag_takes_them(
    example_csv: Path, tmp_path: Path
) -> None:
    import datetime as dt

    by_list = marops.segment(example_csv, dates=["0801", dt.date(2022, 8, 2)], seed=1)
    by_text = marops.segment(example_csv, dates="0801,0802", seed=1)
    assert by_list["depots"] == by_text["depots"]
    assert by_list["depots"] != marops.segment(example_csv, dates="0801", seed=1)["depots"]
    marops.segment(example_csv, out=tmp_path / "depots.json", dates="0801..0810")
    a = marops.plan_window(example_csv, tmp_path / "depots.json", dt.date(2022, 8, 11), 5)
    b = marops.plan_window(example_csv, str(tmp_path / "depots.json"), 811, 5)
    assert a.routes.equals(b.routes)
    # An actor's file as a Path, as every other file keyword takes one.
    actor = Path(__file__).resolve().parents[1] / "policies" / "marops-ops.safetensors"
    by_path = marops.plan_window(example_csv, tmp_path / "depots.json", 811, 5, policy=actor)
    assert by_path.routes.equals(
        marops.plan_window(example_csv, tmp_path / "depots.json", 811, 5, policy=str(actor)).routes
    )
    # A datetime (a pandas Timestamp is one) is its day.
    c = marops.plan_window(example_csv, tmp_path / "depots.json", dt.datetime(2022, 8, 11, 9), 5)
    assert a.routes.equals(c.routes)
    # numpy's datetime64 (a frame's .unique() gives them) is its day, and a numpy array
    # or a pandas Series is a list.
    np = pytest.importorskip("numpy")
    pd = pytest.importorskip("pandas")
    d = marops.plan_window(example_csv, tmp_path / "depots.json", np.datetime64("2022-08-11T09"), 5)
    assert a.routes.equals(d.routes)
    days = pd.to_datetime(["2022-08-01", "2022-08-02"])
    for given in (days.values, list(days.values), pd.Series(days), pd.Series(["0801", "0802"])):
        assert marops.segment(example_csv, dates=given, seed=1)["depots"] == by_text["depots"]
    with pytest.raises(
        InputError, match=r"dates expects a string like 'a,b' or a non-empty list, got"
    ) as e:
        marops.segment(example_csv, dates=pd.Series([{}, {}]))
    assert "\n" not in str(e.value)  # a Series' repr on one line
    for no_day in ([pd.NaT], pd.Series(pd.to_datetime(["2022-08-01", None]))):  # pandas' NaT
        with pytest.raises(InputError, match=r"dates expects a string like 'a,b'"):
            marops.segment(example_csv, dates=no_day)
    with pytest.raises(InputError, match=r"^invalid option date: expected a date"):
        marops.plan_window(example_csv, tmp_path / "depots.json", "0931", 5)
    with pytest.raises(InputError, match="^drones expects whole numbers"):
        marops.evaluate(example_csv, drones=[4, "x"], workers=1)


def test_api_segment_out_names_a_json_file_as_the_flag_does(
    example_csv: Path, tmp_path: Path
) -> None:
    # As `marops segment --out`: a folder or a name of another kind is refused before
    # any work, not a ValueError from deep inside nor JSON under a .csv name.
    for out, this in ((tmp_path, "a folder"), (tmp_path / "depots.csv", "a .csv file")):
        with pytest.raises(InputError, match=f": out names the depots file.*this is {this}"):
            marops.segment(example_csv, out=out)
        with pytest.raises(InputError, match=f": out names the hubs file.*this is {this}"):
            marops.segment(example_csv, out=out, hubs=2)
    with pytest.raises(InputError, match="this is a folder"):
        marops.segment(example_csv, out=".")
    assert list(tmp_path.iterdir()) == []


def test_api_evaluate_checks_its_out_folder_before_any_work(
    example_csv: Path, tmp_path: Path
) -> None:
    # As `marops evaluate --out`: a file is no folder, and a table marops did not write
    # is refused before a replay runs, leaving the folder as it was (no jobs/).
    afile = tmp_path / "afile.txt"
    afile.write_text("x")
    with pytest.raises(InputError, match=": out must be a folder; this is a file"):
        marops.evaluate(example_csv, methods="stay", dates="0811", out=afile, workers=1)
    with pytest.raises(InputError, match="cannot be created"):
        marops.evaluate(example_csv, methods="stay", dates="0811", out=afile / "x", workers=1)
    folder = tmp_path / "ev"
    folder.mkdir()
    (folder / "summary.csv").write_text("mine\n")
    with pytest.raises(InputError, match="summary.csv: exists and was not written by marops"):
        marops.evaluate(example_csv, methods="stay", dates="0811", out=folder, workers=1)
    assert [p.name for p in folder.iterdir()] == ["summary.csv"]
    assert (folder / "summary.csv").read_text() == "mine\n" and afile.read_text() == "x"


def test_api_plan_window_out_is_a_folder_as_the_flag_is(example_csv: Path, tmp_path: Path) -> None:
    # As `marops plan-window --out`: a file's name is refused before any work, not made
    # into a folder named stops.parquet.
    marops.segment(example_csv, out=tmp_path / "depots.json", dates="0801..0810")
    for name in ("stops.parquet", "window.json"):
        with pytest.raises(InputError, match=f"^out is a folder .*not a file: {name}"):
            marops.plan_window(
                example_csv, tmp_path / "depots.json", "0811", 5, out=tmp_path / name
            )
    # The depots file and the journal that lists it (docs/outputs.md): nothing else.
    assert sorted(p.name for p in tmp_path.iterdir()) == [".marops-files.json", "depots.json"]


def test_api_evaluate_returns_the_paired_comparison_with_against(example_csv: Path) -> None:
    # `against` pairs each method's days with the reference's: the table paired.csv
    # holds, here in memory without `out`; a comparison over one day warns, as the
    # command does, at the caller's line.
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ev = marops.evaluate(
            example_csv,
            methods="stay,ops-global",
            dates="0811",
            against="ops-global",
            workers=1,
            area="square",
        )
    assert ev.paired is not None and ev.folder is None
    few = [w for w in caught if "backs the paired comparison" in str(w.message)]
    assert len(few) == 1 and few[0].filename == __file__
    assert str(few[0].message).startswith("only 1 day backs the paired comparison (fewer than")
    rows = ev.paired.to_pylist()
    assert {r["against"] for r in rows} == {"ops-global"} and rows[0]["days"] == 1
    # Without it, the summary's means over one day are no comparison either.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        alone = marops.evaluate(example_csv, methods="stay", dates="0811", workers=1, area="square")
    assert alone.paired is None
    few = [w for w in caught if "backs the comparison" in str(w.message)]
    assert len(few) == 1 and few[0].filename == __file__
    assert alone.summary.column("few_days").to_pylist() == [True]


def test_api_evaluate_returns_the_frontier_of_an_alpha_sweep(
    example_csv: Path, tmp_path: Path
) -> None:
    # Two values of alpha (or frontier=True) give frontier.csv's table in memory too, the
    # same rows as the file, where the result had no frontier and without out it was lost.
    import warnings

    from pyarrow import csv

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # one day: too few to compare, said elsewhere
        common = {"methods": "stay", "dates": "0811", "workers": 1, "area": "square"}
        ev = marops.evaluate(example_csv, alpha="0.2,0.8", plots=False, out=tmp_path, **common)
        alone = marops.evaluate(example_csv, alpha="0.8", **common)
    assert ev.frontier is not None and alone.frontier is None
    assert ev.frontier.column("alpha").to_pylist() == [0.2, 0.8]
    written = csv.read_csv(tmp_path / "frontier.csv")
    assert written.column_names == ev.frontier.column_names
    for name in ("method", "alpha", "delivered", "energy_kj", "dominated"):
        assert written.column(name).to_pylist() == ev.frontier.column(name).to_pylist(), name


def test_api_data_may_be_any_path_like(example_csv: Path) -> None:
    # A path is any os.PathLike, for the data as for out and depots (py.path, PurePath).
    from pathlib import PurePath

    assert marops.read_lade(PurePath(example_csv)).equals(marops.read_lade(str(example_csv)))


def test_api_figures_leave_the_callers_matplotlib_backend(
    example_csv: Path, tmp_path: Path
) -> None:
    # A notebook's backend (inline, here svg) is the caller's: drawing segment's and a
    # day's figures chooses none, in a fresh interpreter where the modules load first.
    import subprocess
    import sys

    code = (
        "import matplotlib, sys, warnings\n"
        "matplotlib.use('svg')\n"
        "warnings.simplefilter('ignore')\n"
        "from marops_cli import api\n"
        "csv, out = sys.argv[1], sys.argv[2]\n"
        "api.segment(csv, out=out + '/depots.json', dates='0801', plot=True)\n"
        "api.replay_day(csv, '0811', method='stay', out=out + '/day', plot=True, area='square')\n"
        "print(matplotlib.get_backend())\n"
    )
    env = {**os.environ, "MAROPS_CACHE_DIR": "off"}
    done = subprocess.run(
        [sys.executable, "-c", code, str(example_csv), str(tmp_path)],
        capture_output=True,
        text=True,
        env=env,
        check=True,
    )
    assert done.stdout.strip() == "svg"
    assert (tmp_path / "depots.png").is_file() and (tmp_path / "day" / "routes.png").is_file()


@pytest.mark.parametrize("before", ["", "replay_day"])
def test_api_workers_in_an_unguarded_script_stop_with_the_reason(
    example_csv: Path, tmp_path: Path, before: str
) -> None:
    # Python's multiprocessing has each worker import the script that started it: one
    # that calls evaluate() outside `if __name__ == "__main__":` fails, naming the
    # remedy once: the parent's one traceback, none from a worker, no Broken pipe's.
    # A call before it (a day replayed) stops a starting worker too: it was run by each
    # worker, which the pool replaced as it stopped, for ever.
    import subprocess
    import sys

    script = tmp_path / "unguarded.py"
    data = repr(str(example_csv))
    first = f"api.replay_day({data}, '0811', area='square')\n" if before else ""
    script.write_text(
        "from marops_cli import api\n"
        + first
        + f"api.evaluate({data}, methods='stay,ops-global', dates='0811', workers=2)\n"
    )
    env = {**os.environ, "MAROPS_CACHE_DIR": str(tmp_path / "cache"), "PYTHONWARNINGS": "ignore"}
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=300
    )
    assert done.returncode == 1
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("marops_cli.errors.RunError: ") and 'if __name__ == "__main__":' in last
    assert "RuntimeError" not in done.stderr
    assert done.stderr.count("Traceback") == 1 and done.stderr.count("errors.RunError:") == 1
    assert "direct cause" not in done.stderr


def test_api_warnings_are_said_at_the_callers_line(example_csv: Path) -> None:
    # A day left partly undelivered warns where the notebook called, not inside marops.
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        marops.replay_day(example_csv, "0811", method="stay", drones=2)
    said = [w for w in caught if "stayed undelivered" in str(w.message)]
    assert said and said[0].filename == __file__


def test_api_a_day_kept_without_the_files_asked_for_now_is_replayed(
    example_csv: Path, tmp_path: Path
) -> None:
    # A day already in out is kept only when it holds what this call asks for: the map
    # asked for now is written, not silently missing.
    day = {"method": "stay", "out": tmp_path, "area": "square"}  # its files in out itself
    first = marops.replay_day(example_csv, "0811", **day)
    assert not (tmp_path / "routes.geojson").exists()
    again = marops.replay_day(example_csv, "0811", **day, geojson=True)
    assert (tmp_path / "routes.geojson").is_file() and again.routes.equals(first.routes)


def test_api_a_kept_day_of_json_route_files_is_read_back(example_csv: Path, tmp_path: Path) -> None:
    """The same call again on a day kept in out as fmt="json" returns its tables read
    from stops.json and routes.json, the same as the first call's, where it looked for
    stops.parquet and raised FileNotFoundError."""
    day = {"method": "stay", "out": tmp_path, "area": "square", "fmt": "json"}
    first = marops.replay_day(example_csv, "0811", **day)
    again = marops.replay_day(example_csv, "0811", **day)
    assert not (tmp_path / "stops.parquet").exists()
    for a, b in ((first.stops, again.stops), (first.routes, again.routes)):
        assert b.equals(a) and b.schema.equals(a.schema, check_metadata=True)
    assert again.metrics == first.metrics


def test_api_a_kept_day_of_json_route_files_reads_back_under_the_route_file_cap(
    example_csv: Path, tmp_path: Path, monkeypatch
) -> None:
    """A kept day's stops.json is read back, and judged marops's, under the route files'
    cap, as the report reads it, not the small inputs' 64 MiB (made smaller than the file
    here): a busy day's JSON marops wrote was refused as larger than 64 MiB, or as not
    written by marops. One past the route files' cap is refused naming it (as no file
    marops wrote, before it would be read back)."""
    import marops_cli.data.jsonfile
    import marops_cli.io.routejson

    day = {"method": "stay", "out": tmp_path, "area": "square", "fmt": "json"}
    first = marops.replay_day(example_csv, "0811", **day)
    path = tmp_path / "stops.json"
    size = path.stat().st_size
    assert size > 10 * (tmp_path / "metrics.json").stat().st_size  # the small files fit
    for module in (marops_cli.data.jsonfile, marops_cli.io.ownership, marops_cli.io.routejson):
        monkeypatch.setattr(module, "MAX_SMALL_FILE", size - 1)
    assert marops.replay_day(example_csv, "0811", **day).stops.equals(first.stops)
    monkeypatch.setattr(marops_cli.io.routejson, "MAX_ROUTE_JSON", size - 1)
    with pytest.raises(InputError, match="stops file is larger than") as err:
        marops.replay_day(example_csv, "0811", **day)
    assert err.value.file == str(path)


def test_api_a_kept_day_of_more_rows_than_a_day_has_is_refused_unread(
    example_csv: Path, tmp_path: Path, monkeypatch
) -> None:
    """A day kept in out is read back; a stops or routes file of more rows than any
    day's (edited since, a megabyte of repeated rows unpacking to gigabytes) is refused
    by its footer, naming it, not returned as the day's routes."""
    import numpy as np

    import marops_cli.config

    day = {"method": "stay", "out": tmp_path, "area": "square"}
    first = marops.replay_day(example_csv, "0811", **day)
    path = tmp_path / "routes.parquet"
    table = pq.read_table(path)
    more = table.take(pa.array(np.arange(10 * table.num_rows) % table.num_rows))
    pq.write_table(more.replace_schema_metadata(table.schema.metadata), path)
    monkeypatch.setattr(marops_cli.config, "MAX_DAY_ROUTES", 9 * first.routes.num_rows)
    with pytest.raises(InputError, match="edited since marops wrote it") as err:
        marops.replay_day(example_csv, "0811", **day)
    assert err.value.file == str(path)


def test_api_a_path_too_long_to_look_up_is_an_input_error(example_csv: Path, tmp_path: Path):
    # As the flags: a folder name longer than the file system takes is bad input naming
    # the path, not an OSError from deep inside.
    (tmp_path / "sub").mkdir()
    long = tmp_path / "sub" / ("x" * 300)
    for call in (
        lambda: marops.plan_window(example_csv, long / "depots.json", "0811", 5),
        lambda: marops.plan_window(example_csv, tmp_path / "d.json", "0811", 5, out=long),
        lambda: marops.replay_day(example_csv, "0811", out=long),
        lambda: marops.read_lade(long / "lade.csv"),
    ):
        with pytest.raises(InputError, match="File name too long") as err:
            call()
        assert str(long) in str(err.value) and "Errno" not in str(err.value)
    assert [p.name for p in tmp_path.iterdir()] == ["sub"] and not any(long.parent.iterdir())


def test_api_an_empty_path_is_an_input_error_not_the_current_folder(
    example_csv: Path, tmp_path: Path, monkeypatch
) -> None:
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InputError, match=r"plan_window\(\): out expects a path, got str ''"):
        marops.plan_window(example_csv, tmp_path / "d.json", "0811", 5, out="")
    with pytest.raises(InputError, match=r"replay_day\(\): out expects a path, got str ''"):
        marops.replay_day(example_csv, "0811", out="")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda d: marops.segment(d, plot=True), r"^segment\(\): plot=True writes files into out"),
        (lambda d: marops.segment(d, geojson=True, hubs=2), r"^segment\(\): geojson=True"),
        (lambda d: marops.plan_window(d, "d.json", "0811", 5, geojson=True), r"geojson=True"),
        (lambda d: marops.plan_window(d, "d.json", "0811", 5, report=True), r"report=True"),
        (lambda d: marops.replay_day(d, "0811", plot=True), r"^replay_day\(\): plot=True"),
        (lambda d: marops.replay_day(d, "0811", geojson=True), r"geojson=True writes files"),
        (lambda d: marops.replay_day(d, "0811", report=True), r"report=True writes files"),
        (lambda d: marops.evaluate(d, report=True, workers=1), r"^evaluate\(\): report=True"),
    ],
)
def test_api_a_file_asked_for_without_out_is_an_input_error(
    example_csv: Path, tmp_path: Path, monkeypatch, call, message
) -> None:
    # Nothing is written without out: a figure, map or page asked for would be silently
    # missing, so asking for one without out is refused before any work.
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InputError, match=message) as err:
        call(example_csv)
    assert "pass out" in str(err.value) and "\n" not in str(err.value)
    assert list(tmp_path.iterdir()) == []


def test_api_evaluate_results_carry_the_files_metadata(example_csv: Path, tmp_path: Path) -> None:
    # As every table the API returns: results carries results.parquet's marops metadata
    # (package, config, input, settings), with out and without.
    one = {"area": "square"}  # one row: one study square's day
    ev = marops.evaluate(
        example_csv, methods="stay", dates="0811", out=tmp_path, workers=1, plots=False, **one
    )
    from_file = pq.read_table(tmp_path / "results.parquet")
    assert ev.results.schema.metadata[b"marops"] == from_file.schema.metadata[b"marops"]
    assert ev.results.equals(from_file)
    # a day is a date, as the route files hold it, so the tables join on it as they are
    assert ev.results.schema.field("day").type == pa.date32()
    assert ev.results.column("day").to_pylist() == [dt.date(2022, 8, 11)]
    in_memory = marops.evaluate(example_csv, methods="stay", dates="0811", workers=1, **one)
    assert in_memory.results.schema.metadata[b"marops"] == from_file.schema.metadata[b"marops"]


def test_api_an_actor_of_another_operating_model_names_the_keyword(example_csv: Path) -> None:
    # The paper's actor under the realistic model (the default) is refused naming the
    # keyword policy, as every API error names its keyword, not the flag --policy.
    shipped = Path(__file__).parents[1] / "policies" / "marops-basic.pt"
    depots = marops.segment(example_csv, dates="0801..0810")
    with pytest.raises(InputError, match="or another policy$") as caught:
        marops.plan_window(example_csv, depots, "0811", 5, policy=str(shipped))
    assert "--policy" not in str(caught.value)


def test_api_errors_name_keywords_not_flags(example_csv: Path, tmp_path: Path) -> None:
    # A window outside the day and a row strict=True makes an error name the API's
    # keywords, where they named the command line's --window and --strict.
    depots = marops.segment(example_csv, dates="0801..0810")
    with pytest.raises(InputError, match=r"^window 99 is outside 0\.\.15$"):
        marops.plan_window(example_csv, depots, "0811", 99)
    bad = tmp_path / "bad.csv"
    lines = example_csv.read_text().splitlines()[:3]
    bad.write_text("\n".join([*lines, lines[1].replace("121.", "521.", 1)]) + "\n")
    with pytest.raises(InputError, match="and strict=True is set") as caught:
        marops.read_lade(bad, strict=True)
    assert "--strict" not in str(caught.value)
