"""The Python API over data in memory (docs/decisions.md, "Application layer"): a pandas
DataFrame or a pyarrow Table plans as its file does, and a call without ``out`` writes
nothing: not in the working folder, not in a temporary folder, not in the depots cache."""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from pathlib import Path

import pyarrow as pa
import pyarrow.csv as pacsv
import pytest

from marops_cli import api as marops
from marops_cli.errors import InputError


def _rows(csv: Path) -> pa.Table:
    """The example's rows as text, as the reader reads the file."""
    names = pacsv.read_csv(csv).column_names
    opts = pacsv.ConvertOptions(column_types={n: pa.string() for n in names})
    return pacsv.read_csv(csv, convert_options=opts)


def _files(*folders: Path) -> set[Path]:
    return {p for f in folders for p in f.rglob("*")}


@pytest.fixture
def quiet_folders(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[list[Path]]:
    """An empty working folder, temporary folder and depots cache, watched by the test."""
    folders = [tmp_path / n for n in ("work", "tmp", "cache")]
    for f in folders:
        f.mkdir()
    monkeypatch.chdir(folders[0])
    monkeypatch.setenv("TMPDIR", str(folders[1]))
    monkeypatch.setattr(tempfile, "tempdir", None)  # gettempdir() reads TMPDIR again
    monkeypatch.setenv("MAROPS_CACHE_DIR", str(folders[2]))
    assert Path(tempfile.gettempdir()) == folders[1]
    yield folders


@pytest.fixture(scope="module")
def depots(example_csv: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("depots") / "depots.json"
    marops.segment(example_csv, out=path, dates="0801..0810")
    return path


def test_a_table_in_memory_plans_as_its_file_and_writes_nothing(
    example_csv: Path, depots: Path, quiet_folders: list[Path]
) -> None:
    rows = _rows(example_csv)
    day = marops.replay_day(rows, date="0811", depots=depots, method="stay")
    window = marops.plan_window(rows, depots, "0811", 5)
    doc = marops.segment(rows, dates="0801..0810")
    # One study square: it segments the other days for its depots.
    no_depots = marops.replay_day(rows, date="0811", method="stay", area="square")
    assert _files(*quiet_folders) == set()

    from_file = marops.replay_day(example_csv, "0811", depots=depots, method="stay")
    assert day.routes.equals(from_file.routes) and day.stops.equals(from_file.stops)
    timing = ("runtime_s", "solver")
    assert {k: v for k, v in day.metrics.items() if k not in timing} == {
        k: v for k, v in from_file.metrics.items() if k not in timing
    }
    assert day.folder is None and day.metrics["requests"] > 0
    assert b"marops" in day.routes.schema.metadata
    assert set(window.routes.column("window").to_pylist()) == {5}
    assert window.metrics["objective"]["G"] > 0 and window.folder is None
    assert doc["meta"]["input"]["name"] == "Table" and len(doc["depots"]) == 16
    assert no_depots.metrics["requests"] == day.metrics["requests"]


def test_a_pandas_frame_plans_and_writes_nothing(
    example_csv: Path, depots: Path, quiet_folders: list[Path]
) -> None:
    import pandas as pd

    frame = _rows(example_csv).to_pandas()
    day = marops.replay_day(frame, date="0811", depots=depots, method="stay")
    window = marops.plan_window(frame, depots, "0811", 5, method="stay")
    assert _files(*quiet_folders) == set()
    assert isinstance(frame, pd.DataFrame)
    assert day.metrics["delivered"] > 0 and window.routes.num_rows > 0
    assert day.routes.to_pandas().shape[0] == day.routes.num_rows
    with pytest.raises(InputError, match="^DataFrame, row 1, column 'lat': missing required"):
        marops.read_lade(frame.drop(columns=["lat"]))


def test_the_depots_segment_returns_plan_as_their_file_does(
    example_csv: Path, depots: Path, quiet_folders: list[Path]
) -> None:
    """``plan_window(df, depots=segment(df))``: the depots document (or a ``Depots``)
    is taken wherever a depots file is, plans as the file does and is recorded by its
    hash; a document that is no depots document is one line naming ``depots``."""
    import json

    from marops_cli.segment.depots import Depots

    rows = _rows(example_csv)
    doc = marops.segment(rows, dates="0801..0810")
    window = marops.plan_window(rows, depots=doc, date="0811", window=5, method="stay")
    from_file = marops.plan_window(rows, depots, "0811", 5, method="stay")
    assert window.routes.equals(from_file.routes) and window.stops.equals(from_file.stops)
    meta = json.loads(window.routes.schema.metadata[b"marops"])
    assert meta["depots_file"]["name"] == "depots" and len(meta["depots_file"]["sha256"]) == 64
    day = marops.replay_day(rows, "0811", depots=Depots.from_dict(doc), method="stay")
    assert day.metrics["delivered"] > 0
    assert _files(*quiet_folders) == set()
    with pytest.raises(InputError, match=r"^depots, column 'hubs': unknown key 'hubs'"):
        marops.plan_window(rows, {"hubs": []}, "0811", 5)


@pytest.mark.parametrize("area", ["square", "hubs"])
def test_evaluate_on_a_table_in_memory_writes_no_depots_cache(
    example_csv: Path,
    tmp_path: Path,
    quiet_folders: list[Path],
    monkeypatch: pytest.MonkeyPatch,
    area: str,
) -> None:
    """As its docstring says: depots segmented from data in memory are not cached, the
    user's cache (HOME, XDG_CACHE_HOME) included; in one study square as over the hubs
    the whole export gets."""
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.setenv("XDG_CACHE_HOME", str(home / ".cache"))
    config = tmp_path / "small.toml"
    config.write_text(f'[data]\narea = "{area}"\nservice_start = "09:00"\nservice_end = "10:00"\n')
    res = marops.evaluate(
        _rows(example_csv), dates="0811", methods="stay", drones="2", workers=1, plots=False,
        config=config,
    )  # fmt: skip
    hubs = res.results.column("hub").to_pylist()
    if area == "square":
        assert hubs == [0]
    else:  # a row for each hub with requests that day
        assert len(hubs) == len(set(hubs)) > 1
    assert _files(*quiet_folders, home) == set()


def test_a_file_without_out_writes_no_depots_cache_unless_one_is_named(
    example_csv: Path, tmp_path: Path, quiet_folders: list[Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A call on a file's path without ``out`` writes nothing either: its depots go into
    the cache only when ``MAROPS_CACHE_DIR`` names one; with ``out`` (as the commands)
    into the default one too (docs/outputs.md, "Depots cache")."""
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.setenv("XDG_CACHE_HOME", str(home / ".cache"))
    monkeypatch.delenv("MAROPS_CACHE_DIR")
    day = {"date": "0811", "method": "stay", "area": "square", "drones": 2}
    marops.replay_day(example_csv, **day)
    assert _files(*quiet_folders, home) == set()
    monkeypatch.setenv("MAROPS_CACHE_DIR", str(quiet_folders[2]))  # asked for by name
    marops.replay_day(example_csv, **day)
    assert [p.suffix for p in (quiet_folders[2] / "depots").iterdir()] == [".npz"]
    monkeypatch.delenv("MAROPS_CACHE_DIR")
    marops.replay_day(example_csv, out=tmp_path / "day", **day)
    assert [p.suffix for p in (home / ".cache" / "marops" / "depots").iterdir()] == [".npz"]


def test_a_table_in_memory_is_checked_as_a_file_is(depots: Path, example_csv: Path) -> None:
    rows = _rows(example_csv)
    with pytest.raises(InputError, match="^Table, row 1, column 'lng': missing required column"):
        marops.replay_day(rows.drop_columns(["lng"]), date="0811", depots=depots)
    bad = rows.set_column(
        rows.column_names.index("accept_time"),
        "accept_time",
        pa.array(["soon"] + rows.column("accept_time").to_pylist()[1:]),
    )
    with pytest.raises(InputError, match="^Table, row 2, column 'accept_time': expected a time"):
        marops.read_lade(bad)
    with pytest.raises(InputError, match="has no data rows"):
        marops.read_lade(rows.slice(0, 0))
    # A day the rows do not hold is said to be missing from them, not from a file.
    with pytest.raises(InputError, match=r"^Table, .*: date 2022-01-01 not in the Table \(it has"):
        marops.replay_day(rows, "0101", depots=depots)


def test_a_frame_reads_its_lade_columns_as_a_file_does(example_csv: Path) -> None:
    # Columns the planner does not read are not read (a file's are not), and a column
    # of mixed cells, as frames joined together hold, is read as its text: a stray
    # word in lat is a dropped row, as in a file.
    import pandas as pd

    frame = pd.read_csv(example_csv)
    base = marops.read_lade(frame)
    extra = frame.assign(note=[1, "a"] * (len(frame) // 2) + [1] * (len(frame) % 2))
    extra["shape"] = [object()] * len(frame)
    assert marops.read_lade(extra).equals(base)
    mixed = frame.astype({"order_id": object, "lat": object})
    mixed.loc[3, "order_id"] = "X3"
    mixed.loc[5, "lat"] = "abc"
    rows = marops.read_lade(mixed)
    assert "X3" in rows.column("order_id").to_pylist() and 7 not in rows.column("row").to_pylist()
    with pytest.raises(InputError, match=r"^DataFrame, row 7, column 'lat': row would be dropped"):
        marops.read_lade(mixed, strict=True)
    # A LaDe column made the frame's index (set_index) is named as such.
    with pytest.raises(InputError, match=r"^DataFrame, row 1, column 'order_id': .*frame's index"):
        marops.read_lade(frame.set_index(["courier_id", "order_id"]))
    twice = pd.concat([frame, frame[["lat"]]], axis=1)
    with pytest.raises(InputError, match="column 'lat' appears 2 times"):
        marops.read_lade(twice)


def test_a_frame_of_float_or_padded_ids_reads_as_its_plain_ids(example_csv: Path) -> None:
    # pandas holds integer ids as floats once the column has a gap (601954.0); a
    # hand-edited frame may pad them. Either is the plain id: the same rows and ids.
    import pandas as pd

    frame = pd.read_csv(example_csv)
    base = marops.read_lade(frame)
    assert marops.read_lade(frame.astype({"order_id": float})).equals(base)
    padded = frame.astype({"order_id": str})
    padded["order_id"] = " " + padded["order_id"] + " "
    assert marops.read_lade(padded).equals(base)


def test_a_frame_column_of_several_kinds_reads_as_its_cells_text(example_csv: Path) -> None:
    # Arrow makes one type of a column of Python objects where it can: integer ids
    # beside a datetime became times of 1970 ("1970-01-01 00:00:00.000001"), every id
    # wrong; a list among the ids became the id "[1]". Each cell reads as its text, as
    # a file's; a cell no file holds is refused by its row.
    import datetime as dt

    import pandas as pd

    frame = pd.read_csv(example_csv)
    ids = frame.astype({"order_id": object})
    ids.loc[0, "order_id"] = dt.datetime(2022, 8, 1)
    got = marops.read_lade(ids).column("order_id").to_pylist()
    want = marops.read_lade(frame).column("order_id").to_pylist()
    assert got[0] == "2022-08-01 00:00:00" and got[1:] == want[1:]
    ids.loc[1, "order_id"] = b"X1"  # bytes as their UTF-8 text
    assert marops.read_lade(ids).column("order_id").to_pylist()[:2] == [got[0], "X1"]
    for cell, shown in (([1], r"\[1\] \(list\)"), ({"a": 1}, r"\{'a': 1\} \(dict\)")):
        odd = frame.astype({"aoi_id": object})
        odd.at[4, "aoi_id"] = cell
        with pytest.raises(
            InputError, match=rf"^DataFrame, row 6, column 'aoi_id': .*got {shown} \(the frame's"
        ):
            marops.read_lade(odd)


class DataFrame:
    """A frame of another library (polars, say): not pandas, whatever its name."""

    columns = ("order_id", "lng", "lat", "accept_time", "delivery_time")


def test_a_frame_of_another_library_is_named_not_read_as_pandas() -> None:
    with pytest.raises(InputError, match=r"or a pyarrow Table, got [\w.]*test_api_in_memory\.Da"):
        marops.read_lade(DataFrame())


def test_calls_without_figures_leave_no_file_in_home(example_csv: Path, tmp_path: Path) -> None:
    # Nothing written unasked, a library's own cache included: matplotlib, whose first
    # import writes its font cache under HOME, loads only to draw a figure.
    import os
    import subprocess
    import sys

    code = (
        "import sys, warnings\n"
        "warnings.simplefilter('ignore')\n"
        "import pandas as pd\n"
        "from marops_cli import api\n"
        "frame = pd.read_csv(sys.argv[1])\n"
        "api.segment(frame, dates='0801..0803')\n"
        "api.replay_day(frame, '0811', method='stay')\n"
        "print('matplotlib' in sys.modules)\n"
    )
    home = tmp_path / "home"
    home.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("XDG_CACHE_HOME", "MPLCONFIGDIR")}
    env.update(HOME=str(home), MAROPS_CACHE_DIR=str(tmp_path / "cache"))
    done = subprocess.run(
        [sys.executable, "-c", code, str(example_csv)],
        capture_output=True,
        text=True,
        env=env,
        cwd=tmp_path,
        check=True,
    )
    assert done.stdout.strip() == "False"
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["home"]


def test_an_error_in_a_frames_row_names_its_index_label(example_csv: Path) -> None:
    # Rows count as in a file (the first is row 2); a frame's own index, as a filtered
    # frame keeps it, finds the row too.
    import pandas as pd

    frame = pd.read_csv(example_csv).astype({"accept_time": object})
    part = frame[frame.lat > 31.14].copy()
    part.loc[part.index[3], "accept_time"] = "soon"
    label = part.index[3]
    assert label != 3
    with pytest.raises(
        InputError, match=rf"^DataFrame, row 5, .*'soon' \(the frame's index {label}\)$"
    ):
        marops.read_lade(part)


def test_decimal_coordinates_read_as_their_digits(example_csv: Path) -> None:
    # A decimal column (a database's NUMERIC, a Parquet DECIMAL) holds the digits a CSV
    # does: read as the same doubles, not Arrow's cast, which misses some by one ulp.
    import pandas as pd

    frame = pd.read_csv(example_csv)
    table = pa.Table.from_pandas(frame, preserve_index=False)
    for name in ("lng", "lat"):
        k = table.column_names.index(name)
        table = table.set_column(k, name, table.column(k).cast(pa.decimal128(12, 6)))
    got, want = marops.read_lade(table), marops.read_lade(frame)
    assert got.column("lng").equals(want.column("lng"))
    assert got.column("lat").equals(want.column("lat"))


def test_float16_coordinates_are_refused_float32_read(example_csv: Path) -> None:
    # float32 holds a coordinate to about a metre; float16 (a frame downcast to save
    # memory) to kilometres, which would plan every request on a coarse grid.
    import pandas as pd

    frame = pd.read_csv(example_csv)
    rows = marops.read_lade(frame.astype({"lng": "float32", "lat": "float32"}))
    assert rows.num_rows == marops.read_lade(frame).num_rows
    with pytest.raises(InputError, match=r"^DataFrame, column 'lat': .* float16, whose numbers"):
        marops.read_lade(frame.astype({"lat": "float16"}))


def test_frames_of_unusual_shapes_read_or_are_named_in_one_line(example_csv: Path) -> None:
    # A sparse column holds the same cells (it was "Did not pass numpy.dtype object");
    # complex numbers are no cell of a file (it was "Unsupported numpy type 15"); column
    # names of two levels (a MultiIndex) were read as "('order_id', 'x')" and said
    # "missing required column 'order_id'".
    import pandas as pd

    frame = pd.read_csv(example_csv)
    sparse = frame.assign(lat=pd.arrays.SparseArray(frame["lat"]))
    assert marops.read_lade(sparse).equals(marops.read_lade(frame))
    with pytest.raises(InputError, match=r"^DataFrame, column 'lng': .* got a column of complex"):
        marops.read_lade(frame.astype({"lng": complex}))
    levels = frame.copy()
    levels.columns = pd.MultiIndex.from_tuples([(c, "x") for c in frame.columns])
    with pytest.raises(InputError, match=r"^DataFrame, row 1: the frame's column names have 2"):
        marops.read_lade(levels)


def test_whole_degree_coordinates_are_refused(example_csv: Path, tmp_path: Path) -> None:
    # Coordinates cast to whole numbers (int32 in a Parquet file) are whole degrees,
    # about 100 km apart: every request would share one or two points.
    import pandas as pd

    frame = pd.read_csv(example_csv, nrows=200)
    path = tmp_path / "whole.parquet"
    frame.astype({"lng": "int32", "lat": "int32"}).to_parquet(path)
    with pytest.raises(
        InputError, match=r"whole.parquet, column 'lng': .* whole numbers \(int32\)"
    ):
        marops.read_lade(path)
    with pytest.raises(InputError, match=r"^DataFrame, column 'lat': .* about 100 km apart"):
        marops.read_lade(frame.astype({"lat": "int64"}))
