"""read_lade on tiny hand-written exports: what is kept, dropped, and refused."""

from __future__ import annotations

import gzip
import hashlib
import os
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq
import pytest

from marops_cli.config import DataConfig
from marops_cli.data.reader import read_lade
from marops_cli.data.table import DROP_REASONS, LADE_COLUMNS
from marops_cli.errors import InputError


def row(
    oid: str,
    lng: str = "121.47",
    lat: str = "31.23",
    acc: str = "08-20 08:00:00",
    dlv: str = "08-20 10:15:00",
    ds: str = "820",
    **extra: str,
) -> dict[str, str]:
    """One LaDe row as text; columns not given get plausible filler."""
    r = {c: "1" for c in LADE_COLUMNS}
    r.update(
        order_id=oid,
        city="Shanghai",
        lng=lng,
        lat=lat,
        accept_time=acc,
        delivery_time=dlv,
        ds=ds,
        aoi_id=f"aoi{oid}",
    )
    r.update(extra)
    return r


def write_csv(path: Path, rows: list[dict[str, str]], columns=LADE_COLUMNS) -> Path:
    lines = [",".join(columns)] + [",".join(r.get(c, "") for c in columns) for r in rows]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


CLEAN = [
    row("1001", "121.4700", "31.2300", "08-20 08:00:00", "08-20 10:15:00"),
    row("1002", "121.4800", "31.2400", "08-20 09:30:00", "08-20 11:00:30"),
    row("1003", "121.4900", "31.2500", "08-19 20:00:00", "08-21 09:00:00", ds="821"),
]


def sec(text: str) -> int:
    return int(np.datetime64(text, "s").astype(np.int64))


def assert_accounted(table) -> None:
    rep = table.report
    assert rep.total == rep.kept + rep.n_dropped
    assert rep.kept == len(table)
    assert set(rep.dropped) == set(DROP_REASONS)


def test_clean_file(tmp_path: Path) -> None:
    path = write_csv(tmp_path / "delivery_sh.csv", CLEAN)
    t = read_lade(path, DataConfig())
    assert list(t.order_id) == ["1001", "1002", "1003"]
    assert all(isinstance(o, str) for o in t.order_id)
    np.testing.assert_allclose(t.lng, [121.47, 121.48, 121.49], rtol=0, atol=1e-12)
    np.testing.assert_allclose(t.lat, [31.23, 31.24, 31.25], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(
        t.accept_s,
        [sec("2022-08-20T08:00:00"), sec("2022-08-20T09:30:00"), sec("2022-08-19T20:00:00")],
    )
    np.testing.assert_array_equal(t.delivery_s[1], sec("2022-08-20T11:00:30"))
    np.testing.assert_array_equal(t.row, [2, 3, 4])
    assert list(t.aoi_id) == ["aoi1001", "aoi1002", "aoi1003"]
    assert t.weight_kg is None
    assert t.report.to_dict() == {"total": 3, "kept": 3, "dropped": dict.fromkeys(DROP_REASONS, 0)}
    data = path.read_bytes()
    assert t.source.name == "delivery_sh.csv"
    assert t.source.size == len(data)
    assert t.source.sha256 == hashlib.sha256(data).hexdigest()
    assert [str(d) for d in t.days()] == ["2022-08-20", "2022-08-21"]


def test_year_setting(tmp_path: Path) -> None:
    t = read_lade(write_csv(tmp_path / "d.csv", CLEAN[:1]), DataConfig(year=2021))
    assert t.accept_s[0] == sec("2021-08-20T08:00:00")


def test_bad_rows_dropped_and_counted(tmp_path: Path) -> None:
    rows = [
        CLEAN[0],
        row("2", lng="0"),  # bad_coordinates (row 3)
        row("3", lat=""),  # bad_coordinates
        row("4", lng="null"),  # bad_coordinates: a placeholder word
        row("5", lat="95.0"),  # bad_coordinates: out of range
        dict(CLEAN[0]),  # duplicate of row 2 (row 7)
        row("6", acc="08-20 12:00:00", dlv="08-20 11:00:00"),  # delivery_before_accept
        row("7", acc=""),  # missing_time
        row("8", dlv=""),  # missing_time
        row("9", acc="", lng="0"),  # both: missing_time wins
        CLEAN[1],
        row("1001", dlv="08-20 10:15:01"),  # same id, other time: not a duplicate
    ]
    t = read_lade(write_csv(tmp_path / "d.csv", rows), DataConfig())
    assert t.report.dropped == {
        "bad_coordinates": 4,
        "duplicate": 1,
        "delivery_before_accept": 1,
        "missing_time": 3,
        "malformed_row": 0,
        "repeated_header": 0,
    }
    assert t.report.total == 12 and t.report.kept == 3
    assert_accounted(t)
    np.testing.assert_array_equal(t.row, [2, 12, 13])
    assert list(t.order_id) == ["1001", "1002", "1001"]


@pytest.mark.parametrize(
    ("bad", "column", "reason"),
    [
        (row("2", lng="0"), "lng", "bad_coordinates"),
        (row("2", lat=""), "lat", "bad_coordinates"),
        (dict(CLEAN[0]), "order_id", "duplicate"),
        (
            row("2", acc="08-20 12:00:00", dlv="08-20 11:00:00"),
            "delivery_time",
            "delivery_before_accept",
        ),
        (row("2", dlv=""), "delivery_time", "missing_time"),
    ],
)
def test_strict_names_first_dropped_row(tmp_path: Path, bad, column: str, reason: str) -> None:
    path = write_csv(tmp_path / "d.csv", [CLEAN[0], bad, row("9", lng="0")])
    read_lade(path, DataConfig())  # fine without --strict
    with pytest.raises(InputError) as err:
        read_lade(path, DataConfig(strict=True))
    e = err.value
    assert (e.row, e.column) == (3, column)
    assert reason in str(e) and "d.csv" in str(e) and "row 3" in str(e)


@pytest.mark.parametrize("marker", ["NULL", "null", "\\N", "NaN", "None", "--"])
def test_a_missing_value_marker_in_a_time_is_a_missing_time(tmp_path: Path, marker: str) -> None:
    """Exports write NULL, \\N or -- for a missing value: in a time, the row is dropped
    as an empty time is (missing_time), and --strict names it."""
    path = write_csv(tmp_path / "d.csv", [CLEAN[0], row("2", dlv=marker), CLEAN[1]])
    t = read_lade(path, DataConfig())
    assert t.report.dropped["missing_time"] == 1 and list(t.order_id) == ["1001", "1002"]
    assert_accounted(t)
    with pytest.raises(InputError, match="missing_time") as err:
        read_lade(path, DataConfig(strict=True))
    assert (err.value.row, err.value.column) == (3, "delivery_time")


def test_strict_clean_file_reads(tmp_path: Path) -> None:
    t = read_lade(write_csv(tmp_path / "d.csv", CLEAN), DataConfig(strict=True))
    assert len(t) == 3


def test_missing_column(tmp_path: Path) -> None:
    cols = [c for c in LADE_COLUMNS if c != "delivery_time"]
    path = write_csv(tmp_path / "nodlv.csv", CLEAN, cols)
    with pytest.raises(InputError) as err:
        read_lade(path, DataConfig())
    e = err.value
    assert (e.row, e.column, e.exit_code) == (1, "delivery_time", 2)
    assert "nodlv.csv" in str(e) and "row 1" in str(e) and "'delivery_time'" in str(e)


def test_a_pickup_export_is_named_as_such(tmp_path: Path) -> None:
    """LaDe-P's pickup export has order_id, lng, lat and accept_time but pickup_time
    where LaDe-D has delivery_time: the missing-column error says which file it is."""
    cols = ["order_id", "region_id", "city", "courier_id", "accept_time"]
    cols += ["time_window_start", "time_window_end", "lng", "lat", "aoi_id", "aoi_type"]
    cols += ["pickup_time", "pickup_gps_time", "pickup_gps_lng", "pickup_gps_lat", "ds"]
    path = write_csv(tmp_path / "pickup_sh.csv", [row("1", pickup_time="08-20 10:15:00")], cols)
    with pytest.raises(InputError, match="missing required column 'delivery_time'") as err:
        read_lade(path, DataConfig())
    assert "it has pickup_time: a LaDe-P pickup export" in str(err.value)


@pytest.mark.parametrize("sep, word", [(";", "semicolons"), ("\t", "tabs"), ("|", "bars")])
def test_a_csv_with_another_separator_is_named_as_such(tmp_path: Path, sep: str, word: str) -> None:
    """A spreadsheet's semicolon (tab, bar) separated export has every column, in one
    header cell: the missing-column error says which separator it found."""
    path = write_csv(tmp_path / "semi.csv", CLEAN)
    path.write_text(path.read_text(encoding="utf-8").replace(",", sep), encoding="utf-8")
    with pytest.raises(InputError, match=f"the header is separated by {word}, not commas"):
        read_lade(path, DataConfig())
    with pytest.raises(InputError) as err:  # a file that is no LaDe export gets no hint
        read_lade(write_csv(tmp_path / "other.csv", [], ["a;b"]), DataConfig())
    assert "separated" not in str(err.value)


@pytest.mark.parametrize("line", ["sep=,", "sep=;", "SEP=|"])
def test_a_spreadsheets_separator_line_above_the_header_is_named(tmp_path: Path, line: str) -> None:
    """A ``sep=,`` line that spreadsheets read (and some exports write) above the
    header: the missing-column error says to delete it."""
    path = write_csv(tmp_path / "sep.csv", CLEAN)
    path.write_text(f"{line}\n" + path.read_text(encoding="utf-8"), encoding="utf-8")
    with pytest.raises(InputError, match=f"the first line is {line!r}, a line for spreadsheets"):
        read_lade(path, DataConfig())


@pytest.mark.parametrize(
    "encoding, name",
    [("utf-16", "UTF-16"), ("utf-16-le", "UTF-16"), ("utf-16-be", "UTF-16"), ("utf-32", "UTF-32")],
)
def test_a_csv_in_utf16_is_named_as_such(tmp_path: Path, encoding: str, name: str) -> None:
    """A spreadsheet's "Unicode text" export (UTF-16, with or without a byte-order mark)
    is told apart from a binary file: the error names its encoding."""
    text = write_csv(tmp_path / "u.csv", CLEAN).read_text(encoding="utf-8")
    path = tmp_path / "wide.csv"
    path.write_bytes(text.encode(encoding))
    with pytest.raises(InputError, match=f"wide.csv: {name} text, not UTF-8"):
        read_lade(path, DataConfig())
    path.write_bytes(bytes(range(256)) * 4)  # binary stays binary
    with pytest.raises(InputError, match="not a CSV or Parquet file"):
        read_lade(path, DataConfig())


def test_extra_columns_and_any_order(tmp_path: Path) -> None:
    cols = ["note", *reversed(LADE_COLUMNS)]
    rows = [dict(r, note="x,y") for r in CLEAN]  # an extra column with a comma
    lines = [",".join(cols)] + [
        ",".join('"x,y"' if c == "note" else r[c] for c in cols) for r in rows
    ]
    path = tmp_path / "shuffled.csv"
    path.write_text("\n".join(lines) + "\n")
    t = read_lade(path, DataConfig())
    ref = read_lade(write_csv(tmp_path / "ref.csv", CLEAN), DataConfig())
    np.testing.assert_array_equal(t.delivery_s, ref.delivery_s)
    np.testing.assert_array_equal(t.lng, ref.lng)
    assert list(t.order_id) == list(ref.order_id)


def test_only_required_columns(tmp_path: Path) -> None:
    cols = ["order_id", "lng", "lat", "accept_time", "delivery_time", "ds"]
    t = read_lade(write_csv(tmp_path / "min.csv", CLEAN, cols), DataConfig())
    assert list(t.aoi_id) == ["", "", ""]


@pytest.mark.parametrize(
    ("column", "value", "expect"),
    [
        ("accept_time", "08-32 08:00:00", "08-32 08:00:00"),
        ("delivery_time", "2022/08/20 10h15", "2022/08/20 10h15"),
        ("accept_time", "02-29 08:00:00", "02-29 08:00:00': February 29 is no day of 2022, "),
        ("ds", "2013", "2013"),
        ("ds", "aug", "aug"),
    ],
)
def test_unparseable_cell_is_an_error(tmp_path: Path, column: str, value: str, expect: str) -> None:
    rows = [CLEAN[0], CLEAN[1], dict(CLEAN[2], **{column: value})]
    path = write_csv(tmp_path / "badtime.csv", rows)
    with pytest.raises(InputError) as err:
        read_lade(path, DataConfig())
    e = err.value
    assert (e.row, e.column) == (4, column)
    msg = str(e)
    assert "badtime.csv" in msg and "row 4" in msg and f"column '{column}'" in msg
    assert expect in msg


def test_error_beats_drop_and_earliest_row_wins(tmp_path: Path) -> None:
    rows = [row("1", lng="0"), row("2", ds="x"), row("3", acc="99-99 00:00:00")]
    with pytest.raises(InputError) as err:
        read_lade(write_csv(tmp_path / "d.csv", rows), DataConfig())
    assert (err.value.row, err.value.column) == (3, "ds")


@pytest.mark.parametrize("blank", ["", "   ", "\t"])
def test_empty_order_id_is_an_error(tmp_path: Path, blank: str) -> None:
    with pytest.raises(InputError) as err:
        read_lade(write_csv(tmp_path / "d.csv", [CLEAN[0], row(blank)]), DataConfig())
    assert (err.value.row, err.value.column) == (3, "order_id")
    assert "expected an order id" in str(err.value)


def test_an_empty_row_is_dropped_as_missing_time(tmp_path: Path) -> None:
    """A row of separators only (a spreadsheet saves rows it formatted as ,,,,) has no
    order id and no times: dropped as missing_time, not refused as an empty id; an
    empty id beside a time is still an error."""
    columns = [*LADE_COLUMNS, "weight_kg"]
    rows = [dict(r, weight_kg="1.2") for r in CLEAN]
    path = write_csv(tmp_path / "d.csv", rows, columns)
    quoted = ",".join(['""'] * len(columns))
    path.write_text(path.read_text() + "," * len(LADE_COLUMNS) + "\n" + quoted + "\n")
    t = read_lade(path, DataConfig())
    assert len(t) == 3 and t.report.dropped["missing_time"] == 2
    assert_accounted(t)
    with pytest.raises(InputError) as err:
        read_lade(path, DataConfig(strict=True))
    assert (err.value.row, err.value.column) == (5, "accept_time")
    half = dict(rows[0], order_id="", accept_time="")
    with pytest.raises(InputError, match="expected an order id"):
        read_lade(write_csv(tmp_path / "h.csv", [*rows, half], columns), DataConfig())


def test_an_order_id_padded_or_written_as_a_float_is_the_same_order(tmp_path: Path) -> None:
    """An id padded with spaces, or an integer id with a fraction .0 (pandas writes ids
    in a column with gaps so), is the order of the plain id: the same text in the
    outputs, the same parcel weight, and an exact repeat is a duplicate."""
    from marops_cli.data.prepare import parcel_weights

    plain = read_lade(write_csv(tmp_path / "plain.csv", CLEAN), DataConfig())
    rows = [
        dict(CLEAN[0], order_id=" 1001 "),
        dict(CLEAN[1], order_id="1002.0"),
        dict(CLEAN[2], order_id="\t1003.00 "),
        dict(CLEAN[0]),  # a repeat of row 2, whose id was padded: a duplicate
        row("A7.0"),  # not a number: kept as written
        row("0042.0"),  # leading zeros stay: the id's digits
        row("1001.5"),  # not integral: kept as written
    ]
    t = read_lade(write_csv(tmp_path / "messy.csv", rows), DataConfig())
    assert list(t.order_id) == ["1001", "1002", "1003", "A7.0", "0042", "1001.5"]
    assert t.report.dropped["duplicate"] == 1
    np.testing.assert_array_equal(t.row, [2, 3, 4, 6, 7, 8])
    np.testing.assert_array_equal(
        parcel_weights(t.order_id[:3], DataConfig()), parcel_weights(plain.order_id, DataConfig())
    )
    assert_accounted(t)
    # A float column in Parquet: integral ids as their digits, NaN no id at all.
    base = pq.read_table(_as_parquet(tmp_path, "d.parquet"))
    k = base.schema.get_field_index("order_id")
    floats = base.set_column(k, "order_id", pa.array([1001.0, 1002.0, 1003.0]))
    pq.write_table(floats, tmp_path / "f.parquet")
    assert list(read_lade(tmp_path / "f.parquet", DataConfig()).order_id) == list(plain.order_id)
    pq.write_table(
        base.set_column(k, "order_id", pa.array([1001.0, float("nan"), 1003.0])),
        tmp_path / "nan.parquet",
    )
    with pytest.raises(InputError) as err:
        read_lade(tmp_path / "nan.parquet", DataConfig())
    assert (err.value.row, err.value.column) == (3, "order_id")


def test_full_date_format_equals_short(tmp_path: Path) -> None:
    full = [
        dict(r, accept_time="2022-" + r["accept_time"], delivery_time="2022-" + r["delivery_time"])
        for r in CLEAN
    ]
    a = read_lade(write_csv(tmp_path / "full.csv", full), DataConfig())
    b = read_lade(write_csv(tmp_path / "short.csv", CLEAN), DataConfig())
    np.testing.assert_array_equal(a.accept_s, b.accept_s)
    np.testing.assert_array_equal(a.delivery_s, b.delivery_s)


def test_not_a_lade_file(tmp_path: Path) -> None:
    path = tmp_path / "people.csv"
    path.write_text("name,age\nann,31\n")
    with pytest.raises(InputError) as err:
        read_lade(path, DataConfig())
    assert "people.csv" in str(err.value) and err.value.row == 1
    assert "not a LaDe delivery file" in str(err.value)


def test_a_row_longer_than_a_parser_block_is_named(tmp_path: Path) -> None:
    """A field of 33 MiB in the third data row (row 4 with the header): one line naming
    the row and the bound, not the parser's words about block boundaries."""
    rows = [*CLEAN[:2], row("1004", city="x" * (33 << 20)), CLEAN[2]]
    path = write_csv(tmp_path / "long.csv", rows)
    with pytest.raises(InputError) as err:
        read_lade(path, DataConfig())
    assert err.value.row == 4 and "a row longer than 16 MiB" in err.value.message


def test_a_header_longer_than_a_mebibyte_is_read_whole(tmp_path: Path) -> None:
    """A header of 100,000 extra columns runs past the first MiB: it is read to its line
    end (it was cut there, and every row refused as of more fields than the header)."""
    extra = [f"extra_{i}" for i in range(100_000)]
    lines = [",".join([*LADE_COLUMNS, *extra])]
    lines += [line + "," * len(extra) for line in _lines(CLEAN)]
    path = tmp_path / "wide.csv"
    path.write_text("\n".join(lines) + "\n")
    assert path.stat().st_size > 1 << 20 and len(lines[0]) > 1 << 20
    t = read_lade(path, DataConfig())
    assert list(t.order_id) == ["1001", "1002", "1003"]
    assert t.report.describe("wide.csv") == "wide.csv: 3 rows read, none dropped"


def test_binary_file(tmp_path: Path) -> None:
    path = tmp_path / "image.png"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)))
    with pytest.raises(InputError, match="image.png.*not a CSV or Parquet file"):
        read_lade(path, DataConfig())


@pytest.mark.parametrize(
    "magic",
    [b"PK\x03\x04\x14\x00\x06\x00", b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1"],
    ids=["xlsx", "xls"],
)
def test_a_workbook_named_csv_is_named_as_one(tmp_path: Path, magic: bytes) -> None:
    """An Excel workbook saved under a .csv name (a ZIP or an OLE2 archive) is told
    apart from any binary file: the error says to save the sheet as CSV."""
    path = tmp_path / "orders.csv"
    path.write_bytes(magic + bytes(range(256)) * 4)
    with pytest.raises(
        InputError, match="orders.csv: .*spreadsheet workbook.*save the sheet as CSV"
    ):
        read_lade(path, DataConfig())


def test_fake_parquet_suffix(tmp_path: Path) -> None:
    path = write_csv(tmp_path / "d.parquet", CLEAN)
    with pytest.raises(InputError, match="d.parquet.*not a Parquet file"):
        read_lade(path, DataConfig())


@pytest.mark.parametrize(
    ("text", "msg"),
    [("", "empty"), ("\n\n", "empty"), (",".join(LADE_COLUMNS) + "\n", "no data rows")],
)
def test_empty_files(tmp_path: Path, text: str, msg: str) -> None:
    path = tmp_path / "empty.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=msg) as err:
        read_lade(path, DataConfig())
    assert "empty.csv" in str(err.value)


def test_header_without_a_line_end_has_no_data_rows(tmp_path: Path) -> None:
    """The header alone with no newline is the header-only file, not a parser failure."""
    path = tmp_path / "h.csv"
    path.write_text(",".join(LADE_COLUMNS))
    with pytest.raises(InputError, match=r"h.csv, row 2: the file has a header but no data rows"):
        read_lade(path, DataConfig())
    path.write_text("hello,world")  # one line that is no LaDe header: named as such
    with pytest.raises(InputError, match="missing required column 'order_id'"):
        read_lade(path, DataConfig())


def test_a_pipe_is_refused_without_blocking(tmp_path: Path) -> None:
    """A named pipe nobody writes to would block the open for ever: refused unopened,
    pointing at ``-`` (standard input)."""
    fifo = tmp_path / "lade.csv"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match=r"lade.csv: is not a regular file .* give - "):
        read_lade(fifo, DataConfig())


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="nothere.csv.*not found"):
        read_lade(tmp_path / "nothere.csv", DataConfig())


def _lines(rows: list[dict[str, str]]) -> list[str]:
    return [",".join(r[c] for c in LADE_COLUMNS) for r in rows]


def test_a_row_of_another_number_of_fields_is_dropped_and_later_rows_keep_their_numbers(
    tmp_path: Path,
) -> None:
    """A line cut short (an interrupted export) or with a field too many is dropped as
    malformed_row; the rows after it keep their numbers in the file, in the kept rows
    and in errors, and --strict names it."""
    header = ",".join(LADE_COLUMNS)
    a, b, c = _lines(CLEAN)
    extra = _lines([row("5")])[0] + ",x"
    # Rows: 2 a, 3 extra, (blank), 4 b, 5 c, 6 cut short with no line end.
    text = "\n".join([header, a, extra, "", b, c, a[:30]])
    path = tmp_path / "ragged.csv"
    path.write_text(text)
    t = read_lade(path, DataConfig())
    assert list(t.order_id) == ["1001", "1002", "1003"]
    np.testing.assert_array_equal(t.row, [2, 4, 5])
    assert t.report.dropped["malformed_row"] == 2 and t.report.total == 5
    assert_accounted(t)
    with pytest.raises(InputError) as err:
        read_lade(path, DataConfig(strict=True))
    assert err.value.row == 3 and err.value.column is None
    assert "malformed_row: 18 fields, the header has 17" in str(err.value)
    # An error past a malformed row names the row of the file.
    bad = _lines([dict(CLEAN[2], delivery_time="08-32 10:00:00")])[0]
    path.write_text("\n".join([header, a, a[:30], b, bad]) + "\n")
    with pytest.raises(InputError) as err:
        read_lade(path, DataConfig())
    assert (err.value.row, err.value.column) == (5, "delivery_time")
    # --strict names the first row in the file of any reason.
    dup = _lines([CLEAN[0]])[0]
    path.write_text("\n".join([header, a, dup, b, a[:30]]) + "\n")
    with pytest.raises(InputError) as err:
        read_lade(path, DataConfig(strict=True))
    assert (err.value.row, err.value.column) == (3, "order_id")


def test_a_last_line_cut_inside_its_last_field_is_dropped(tmp_path: Path) -> None:
    """An export interrupted inside its last line's last field (LaDe's ds) leaves it the
    header's number of fields: the cell that does not read is the cut, and the line is
    dropped as malformed_row (the file was refused). A file that ends with a line end,
    or whose cut line fails in another column, is refused as before."""
    header = ",".join(LADE_COLUMNS)
    text = "\n".join([header, *_lines(CLEAN)])
    for name, data in (
        ("cut.csv", text[:-2].encode()),
        ("cut.csv.gz", gzip.compress(text[:-1].encode())),
    ):
        path = tmp_path / name
        path.write_bytes(data)
        t = read_lade(path, DataConfig())
        assert list(t.order_id) == ["1001", "1002"]
        assert t.report.dropped["malformed_row"] == 1 and t.report.total == 3
        assert_accounted(t)
        with pytest.raises(InputError) as err:
            read_lade(path, DataConfig(strict=True))
        assert err.value.row == 4 and "malformed_row: cut short" in str(err.value)
    path = tmp_path / "ended.csv"
    path.write_text(text[:-2] + "\n")
    with pytest.raises(InputError, match="expected a date MMDD in 2022, got '8'"):
        read_lade(path, DataConfig())
    bad = _lines([dict(CLEAN[2], delivery_time="08-32 10:00:00")])[0]
    path.write_text("\n".join([header, *_lines(CLEAN[:2]), bad[:-1]]))
    with pytest.raises(InputError) as err:
        read_lade(path, DataConfig())
    assert (err.value.row, err.value.column) == (4, "delivery_time")


def test_a_file_of_mostly_malformed_rows_is_refused(tmp_path: Path) -> None:
    """Most rows of another number of fields is no cut line but another layout (another
    separator in the rows): the file is refused, naming the first."""
    lines = _lines(CLEAN)
    text = "\n".join([",".join(LADE_COLUMNS), lines[0], *(x.replace(",", ";") for x in lines)])
    path = tmp_path / "ragged.csv"
    path.write_text(text + "\n")
    with pytest.raises(InputError) as err:
        read_lade(path, DataConfig())
    assert "ragged.csv" in str(err.value) and "not a valid CSV" in str(err.value)
    assert "Expected 17 columns, got 1" in str(err.value) and err.value.row == 3


def test_the_header_line_again_is_dropped(tmp_path: Path) -> None:
    """Two exports written one after the other repeat the header (with its byte-order
    mark, padded, quoted): the line is dropped as repeated_header, not a bad time."""
    header = ",".join(LADE_COLUMNS)
    quoted = {"lat": '"lat"', "accept_time": " accept_time "}
    again = ",".join(quoted.get(c, c) for c in LADE_COLUMNS)
    a, b, c = _lines(CLEAN)
    path = tmp_path / "twice.csv"
    path.write_text("\n".join([header, a, "\ufeff" + header, b, again, c]) + "\n")
    t = read_lade(path, DataConfig())
    assert list(t.order_id) == ["1001", "1002", "1003"]
    np.testing.assert_array_equal(t.row, [2, 4, 6])
    assert t.report.dropped["repeated_header"] == 2
    assert_accounted(t)
    with pytest.raises(InputError, match="repeated_header") as err:
        read_lade(path, DataConfig(strict=True))
    assert err.value.row == 3
    # A row holding the name in order_id alone is no header: an order like any other.
    path.write_text("\n".join([header, a, _lines([row("order_id")])[0]]) + "\n")
    t = read_lade(path, DataConfig())
    assert list(t.order_id) == ["1001", "order_id"]


def _as_parquet(tmp_path: Path, name: str) -> Path:
    """The CLEAN rows as Parquet with numbers typed as numbers (as real Parquet exports)."""
    t = pa.table({c: [r[c] for r in CLEAN] for c in LADE_COLUMNS})
    t = t.set_column(
        t.schema.get_field_index("order_id"),
        "order_id",
        pa.array([int(r["order_id"]) for r in CLEAN]),
    )
    for c in ("lng", "lat"):
        t = t.set_column(t.schema.get_field_index(c), c, pa.array([float(r[c]) for r in CLEAN]))
    t = t.set_column(t.schema.get_field_index("ds"), "ds", pa.array([int(r["ds"]) for r in CLEAN]))
    pq.write_table(t, tmp_path / name)
    return tmp_path / name


@pytest.mark.parametrize("name", ["d.parquet", "d.pq", "d_no_suffix"])
def test_parquet_equals_csv(tmp_path: Path, name: str) -> None:
    a = read_lade(_as_parquet(tmp_path, name), DataConfig())
    b = read_lade(write_csv(tmp_path / "d.csv", CLEAN), DataConfig())
    for field in ("order_id", "lng", "lat", "accept_s", "delivery_s", "aoi_id", "row"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    assert a.report == b.report


def test_a_parquet_column_of_numbers_holds_numbers_or_text(tmp_path: Path) -> None:
    """Categorical (dictionary-encoded) text and unannotated strings (binary) read as the
    text; booleans are refused naming the column, instead of reading as longitudes 0 and 1."""
    path = _as_parquet(tmp_path, "d.parquet")
    t = pq.read_table(path)
    i = t.schema.get_field_index("lng")
    text = pa.array([str(v) for v in t["lng"].to_pylist()])
    pq.write_table(t.set_column(i, "lng", text.dictionary_encode()), tmp_path / "cat.parquet")
    got = read_lade(tmp_path / "cat.parquet", DataConfig())
    np.testing.assert_array_equal(got.lng, read_lade(path, DataConfig()).lng)
    # Unannotated strings (binary) are text here too, as in the id and time columns.
    pq.write_table(t.set_column(i, "lng", text.cast(pa.binary())), tmp_path / "bin.parquet")
    got = read_lade(tmp_path / "bin.parquet", DataConfig())
    np.testing.assert_array_equal(got.lng, read_lade(path, DataConfig()).lng)
    flags = pa.array([True] * t.num_rows)
    pq.write_table(t.set_column(i, "lng", flags), tmp_path / "flags.parquet")
    with pytest.raises(InputError, match=r"flags.parquet, column 'lng': .* type bool"):
        read_lade(tmp_path / "flags.parquet", DataConfig())


@pytest.mark.parametrize(
    ("column", "cell"), [("lng", "null"), ("lat", "n/a"), ("weight_kg", "--"), ("order_id", "")]
)
def test_a_categorical_parquet_column_reads_as_its_plain_column(
    tmp_path: Path, column: str, cell: str
) -> None:
    """A dictionary-encoded (categorical) column whose text cell holds no number reads as
    the same cells in a plain text column: a bad row dropped, or the same one-line error
    naming row and column, never an Arrow error."""
    path = _as_parquet(tmp_path, "d.parquet")
    t = pq.read_table(path)
    n = t.num_rows
    if column == "weight_kg":
        t = t.append_column("weight_kg", pa.array(["0.5"] * n))
    i = t.schema.get_field_index(column)
    cells = [str(v) for v in t[column].to_pylist()]
    cells[1] = cell
    plain, cat = tmp_path / "plain.parquet", tmp_path / "cat.parquet"
    pq.write_table(t.set_column(i, column, pa.array(cells)), plain)
    pq.write_table(t.set_column(i, column, pa.array(cells).dictionary_encode()), cat)
    assert pa.types.is_dictionary(pq.read_schema(cat).field(column).type)
    try:
        want = read_lade(plain, DataConfig())
    except InputError as exc:
        with pytest.raises(InputError) as got:
            read_lade(cat, DataConfig())
        assert got.value.message == exc.message
        assert (got.value.row, got.value.column) == (exc.row, exc.column) == (3, column)
        return
    got = read_lade(cat, DataConfig())
    assert got.report == want.report and got.report.kept == n - 1
    np.testing.assert_array_equal(got.lng, want.lng)
    np.testing.assert_array_equal(got.row, want.row)


@pytest.mark.parametrize(
    ("column", "values", "expect"),
    [
        ("order_id", lambda n: [[i] for i in range(n)], r"column 'order_id': .* type list"),
        ("aoi_id", lambda n: [{"a": i} for i in range(n)], r"column 'aoi_id': .* type struct"),
        ("ds", lambda n: [[820]] * n, r"column 'ds': .* type list"),
        ("accept_time", lambda n: [["08-20 08:00:00"]] * n, r"column 'accept_time': .* list"),
        ("order_id", lambda n: [True] * n, r"column 'order_id': .* type bool"),
        ("order_id", lambda n: [b"1", b"\xff2", b"3"][:n], r"row 3, column 'order_id': not UTF-8"),
    ],
)
def test_a_parquet_column_of_ids_or_times_holds_text_numbers_or_times(
    tmp_path: Path, column: str, values, expect: str
) -> None:
    """A list, a struct or a boolean is no id, day or time: one line naming the column,
    not a failed cast; binary text (Parquet without the UTF-8 annotation) must be UTF-8."""
    t = pq.read_table(_as_parquet(tmp_path, "d.parquet"))
    i = t.schema.get_field_index(column)
    pq.write_table(t.set_column(i, column, pa.array(values(t.num_rows))), tmp_path / "x.parquet")
    with pytest.raises(InputError, match=expect):
        read_lade(tmp_path / "x.parquet", DataConfig())


def test_parquet_binary_text_and_huge_integers(tmp_path: Path) -> None:
    """Unannotated binary ids read as their text; integers in ``lng``, beyond 2**53 or
    not, are no coordinates: the column is refused by name, not a failed cast."""
    path = _as_parquet(tmp_path, "d.parquet")
    t = pq.read_table(path)
    i = t.schema.get_field_index("order_id")
    ids = t["order_id"].cast(pa.string()).cast(pa.binary())
    pq.write_table(t.set_column(i, "order_id", ids), tmp_path / "bin.parquet")
    got = read_lade(tmp_path / "bin.parquet", DataConfig())
    np.testing.assert_array_equal(got.order_id, read_lade(path, DataConfig()).order_id)
    j = t.schema.get_field_index("lng")
    huge = pa.array([2**62, 2**63 - 1, 121], pa.int64())
    pq.write_table(t.set_column(j, "lng", huge), tmp_path / "huge.parquet")
    with pytest.raises(InputError, match=r"huge.parquet, column 'lng': .* whole numbers \(int64\)"):
        read_lade(tmp_path / "huge.parquet", DataConfig())


def test_parquet_times_with_fractions_of_a_second_read_as_whole_seconds(tmp_path: Path) -> None:
    """pandas writes times as timestamp[ms|us|ns]; a fraction of a second is dropped as
    the text times have none (a time the zone database cannot place is a bad time)."""
    path = _as_parquet(tmp_path, "d.parquet")
    t = pq.read_table(path)
    plain = read_lade(path, DataConfig())
    for unit, scale in (("ms", 1_000), ("us", 1_000_000), ("ns", 1_000_000_000)):
        out = t
        for name in ("accept_time", "delivery_time"):
            secs = {"accept_time": plain.accept_s, "delivery_time": plain.delivery_s}[name]
            ticks = secs.astype(np.int64) * scale + scale // 4  # a quarter second past
            out = out.set_column(
                out.schema.get_field_index(name), name, pa.array(ticks, pa.timestamp(unit))
            )
        pq.write_table(out, tmp_path / f"{unit}.parquet")
        got = read_lade(tmp_path / f"{unit}.parquet", DataConfig())
        np.testing.assert_array_equal(got.accept_s, plain.accept_s)
        np.testing.assert_array_equal(got.delivery_s, plain.delivery_s)


def test_parquet_times_beyond_the_year_9999_are_one_error_naming_the_cell(
    tmp_path: Path,
) -> None:
    """A Parquet time or date no calendar date holds (a timestamp past the year 9999, a
    ``ds`` date32 of 2**31 - 1 days) is one error naming its row and column, with its stored
    count in the message: no traceback from the check, nor later from the day list."""
    t = pq.read_table(_as_parquet(tmp_path, "d.parquet"))
    ms = sec("2022-08-20T08:00:00") * 1000
    day = sec("2022-08-20T00:00:00") // 86_400
    cases = (
        ("delivery_time", pa.array([ms, 2**60, ms]).cast(pa.timestamp("ms"))),
        ("accept_time", pa.array([ms, -(2**60), ms]).cast(pa.timestamp("ms"))),
        ("delivery_time", pa.array([ms, 2**60, ms]).cast(pa.timestamp("ms", "UTC"))),
        ("ds", pa.array([day, 2**31 - 1, day], pa.int32()).cast(pa.date32())),
    )
    for name, column in cases:
        bad = t.set_column(t.schema.get_field_index(name), name, column)
        pq.write_table(bad, tmp_path / "far.parquet")
        with pytest.raises(InputError, match="outside the years 1-9999") as err:
            read_lade(tmp_path / "far.parquet", DataConfig())
        assert (err.value.row, err.value.column) == (3, name)


def test_text_in_arrow_view_layouts_reads_as_text(tmp_path: Path) -> None:
    """string_view and binary_view columns (polars' to_arrow() writes them, and Parquet
    files keep them) are text like string columns, in a file and in memory: they were
    refused as "expected a column of text, numbers or times"."""
    from marops_cli.data.reader import read_lade_table

    path = _as_parquet(tmp_path, "d.parquet")
    plain = read_lade(path, DataConfig())
    t = pq.read_table(path)
    views = {
        "order_id": t["order_id"].cast(pa.string()).cast(pa.string_view()),
        "accept_time": t["accept_time"].cast(pa.string_view()),
        "delivery_time": t["delivery_time"].cast(pa.binary()).cast(pa.binary_view()),
        "lat": t["lat"].cast(pa.string()).cast(pa.string_view()),
    }
    for name, column in views.items():
        t = t.set_column(t.schema.get_field_index(name), name, column)
    pq.write_table(t, tmp_path / "views.parquet")
    for got in (
        read_lade(tmp_path / "views.parquet", DataConfig()),
        read_lade_table(t, DataConfig()),
    ):
        np.testing.assert_array_equal(got.order_id, plain.order_id)
        np.testing.assert_array_equal(got.accept_s, plain.accept_s)
        np.testing.assert_array_equal(got.delivery_s, plain.delivery_s)
        np.testing.assert_array_equal(got.lat, plain.lat)


def test_parquet_text_that_is_not_utf8_names_its_row_and_column(tmp_path: Path) -> None:
    """pyarrow reads Parquet strings without checking them: bytes that are not UTF-8 in
    a text column are one error naming the row and column, as in a CSV."""
    t = pq.read_table(_as_parquet(tmp_path, "d.parquet"))
    for name in ("accept_time", "delivery_time"):
        cells = [str(v).encode() for v in t[name].to_pylist()]
        cells[1] = b"08-01 \xb1:00:00"
        bad = pa.array(cells, pa.binary()).view(pa.string())
        pq.write_table(
            t.set_column(t.schema.get_field_index(name), name, bad), tmp_path / "u.parquet"
        )
        with pytest.raises(InputError, match="not UTF-8") as err:
            read_lade(tmp_path / "u.parquet", DataConfig())
        assert (err.value.row, err.value.column) == (3, name)


def test_a_damaged_parquet_file_is_one_line_naming_it(tmp_path: Path) -> None:
    """A Parquet file cut short or with bytes flipped raises OSError or a thrift error in
    pyarrow as often as ArrowException: each is "not a valid Parquet file" with the file
    named, never a traceback."""
    good = _as_parquet(tmp_path, "d.parquet").read_bytes()
    empty = b"PAR1" + bytes(100) + b"PAR1"
    rng = np.random.default_rng(4)
    damaged = [empty, good[: len(good) // 2] + good[-8:]]
    for _ in range(30):
        flipped = bytearray(good)
        for at in rng.integers(4, len(good) - 8, 3):
            flipped[at] ^= 0xFF
        damaged.append(bytes(flipped))
    refused = 0
    for k, data in enumerate(damaged):
        path = tmp_path / f"bad{k}.parquet"
        path.write_bytes(data)
        try:
            read_lade(path, DataConfig())
        except InputError as exc:
            assert exc.file == str(path) and "\n" not in str(exc)
            refused += 1
    assert refused >= 2  # the empty and the cut files at least; a flip may miss every check


def test_parquet_ds_past_int64_is_a_bad_date(tmp_path: Path) -> None:
    """``ds`` stored as unsigned 64-bit integers beyond int64 is a bad date named by row
    and column, not a failed cast."""
    t = pq.read_table(_as_parquet(tmp_path, "d.parquet"))
    ds = pa.array([2**64 - 1, 801, 801], pa.uint64())
    pq.write_table(t.set_column(t.schema.get_field_index("ds"), "ds", ds), tmp_path / "u.parquet")
    with pytest.raises(InputError, match="expected a date") as err:
        read_lade(tmp_path / "u.parquet", DataConfig())
    assert (err.value.row, err.value.column) == (2, "ds")


def test_parquet_ds_as_dates_or_times_reads_as_its_date(tmp_path: Path) -> None:
    """A ds a DataFrame parsed into dates or times (``pd.to_datetime(ds, format="%m%d")``
    gives 1900-08-20 00:00) is its date, as a date32 ds already was: a timestamp ds was
    refused as "expected a date MMDD"."""
    import datetime as dt

    t = pq.read_table(_as_parquet(tmp_path, "d.parquet"))
    days = [dt.datetime(1900, 8, 20), dt.datetime(1900, 8, 20), dt.datetime(1900, 8, 21)]
    for ds in (
        pa.array(days, pa.timestamp("ns")),
        pa.array(days, pa.timestamp("ms", "UTC")),
        pa.array([d.date() for d in days], pa.date32()),
    ):
        out = t.set_column(t.schema.get_field_index("ds"), "ds", ds)
        pq.write_table(out, tmp_path / "ds.parquet")
        assert read_lade(tmp_path / "ds.parquet", DataConfig()).report.kept == 3


def test_gzip_csv(tmp_path: Path) -> None:
    plain = write_csv(tmp_path / "d.csv", CLEAN)
    for name in ("d.csv.gz", "d_gz_no_suffix"):
        gz = tmp_path / name
        gz.write_bytes(gzip.compress(plain.read_bytes()))
        t = read_lade(gz, DataConfig())
        np.testing.assert_array_equal(t.delivery_s, read_lade(plain, DataConfig()).delivery_s)


def test_a_gzip_stream_damaged_past_its_first_megabyte_is_one_error(tmp_path: Path) -> None:
    """The header is read from the first megabyte; damage further on (a stream cut
    short, a flipped byte, bytes after its end) surfaced as zlib's OSError with exit 1
    and no file named. It is now one error naming the file, exit 2."""
    rows = [row(str(i)) for i in range(30_000)]  # about 2 MB of text
    packed = gzip.compress(write_csv(tmp_path / "d.csv", rows).read_bytes())
    flipped = bytearray(packed)
    flipped[len(packed) // 2] ^= 0xFF
    for name, data in (
        ("cut.csv.gz", packed[: len(packed) * 3 // 4]),
        ("flipped.csv.gz", bytes(flipped)),
        ("trailing.csv.gz", packed + b"not gzip"),
    ):
        (tmp_path / name).write_bytes(data)
        with pytest.raises(InputError, match=f"{name}: not a valid gzip file") as err:
            read_lade(tmp_path / name, DataConfig())
        assert err.value.exit_code == 2


def test_an_export_larger_than_marops_reads_is_refused_before_it_is_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A few megabytes of gzip or Parquet may unpack to tens of gigabytes of repeated
    rows (a 3.7 MB Parquet file of 50 million, a run's memory filled before any error).
    Beyond the bounds (lowered here: 2,000 rows, 64 KiB of text) one line names the
    file, exit 2: a Parquet file by its footer, a gzip as its text is read, a plain CSV
    by its size; within them the same rows read as before."""
    import marops_cli.data.reader as reader

    rows = [row(str(i)) for i in range(3_000)]  # about 200 KB of text
    plain = write_csv(tmp_path / "d.csv", rows)
    (tmp_path / "d.csv.gz").write_bytes(gzip.compress(plain.read_bytes()))
    kept = {name: len(read_lade(tmp_path / name, DataConfig())) for name in ("d.csv", "d.csv.gz")}
    monkeypatch.setattr(reader, "MAX_EXPORT_BYTES", 64 << 10)
    for name, why in (("d.csv", "the file has"), ("d.csv.gz", "its text unpacks to more")):
        with pytest.raises(InputError, match=f"{name}: {why} .*split it by city or by date") as e:
            read_lade(tmp_path / name, DataConfig())
        assert e.value.exit_code == 2
    monkeypatch.setattr(reader, "MAX_EXPORT_BYTES", 4 << 30)
    monkeypatch.setattr(reader, "MAX_EXPORT_ROWS", 2_000)
    big = tmp_path / "big.parquet"
    text = pacsv.ConvertOptions(column_types=dict.fromkeys(LADE_COLUMNS, pa.string()))
    pq.write_table(pacsv.read_csv(plain, convert_options=text), big)
    with pytest.raises(InputError, match=r"big.parquet: holds 3,000 rows, more than the 2,000"):
        read_lade(big, DataConfig())
    with pytest.raises(InputError, match=r"d.csv: holds 3,000 rows, more than the 2,000"):
        read_lade(plain, DataConfig())  # short rows within the bytes: the same bound
    monkeypatch.setattr(reader, "MAX_EXPORT_ROWS", 3_000)
    assert len(read_lade(big, DataConfig())) == kept["d.csv"] == kept["d.csv.gz"]
    # One 1,000-character id in every row: a dictionary of one entry in the file, 3 MB
    # once read, which no footer tells.
    long = pacsv.read_csv(plain, convert_options=text)
    ids = pa.array(["x" * 1000] * long.num_rows)
    pq.write_table(long.set_column(0, "order_id", ids), tmp_path / "long.parquet")
    assert (tmp_path / "long.parquet").stat().st_size < 200_000
    monkeypatch.setattr(reader, "MAX_EXPORT_BYTES", 1 << 20)
    with pytest.raises(InputError, match=r"long.parquet: its columns unpack to more than"):
        read_lade(tmp_path / "long.parquet", DataConfig())


def test_bytes_that_are_not_utf8_in_a_column_not_read_do_not_matter(tmp_path: Path) -> None:
    """A column marops does not read (city, in GBK here) is not read at all: its bytes
    cannot stop a run. Bytes that are not UTF-8 in a column it reads are an error
    naming that cell, within the file's first bytes or past them."""
    rows = [row(str(1000 + i), lng=f"{121.40 + 0.001 * i:.4f}") for i in range(80)]
    text = write_csv(tmp_path / "d.csv", rows).read_bytes()
    plain = read_lade(tmp_path / "d.csv", DataConfig())
    gbk = text.replace(b"Shanghai", "上海市".encode("gbk"))
    (tmp_path / "gbk.csv").write_bytes(gbk)
    t = read_lade(tmp_path / "gbk.csv", DataConfig())
    assert list(t.order_id) == list(plain.order_id) and len(t) == 80
    np.testing.assert_array_equal(t.lng, plain.lng)
    for k in (3, 60):  # row 5 in the first 4 KiB, row 62 past them
        lines = gbk.split(b"\n")
        lines[k + 1] = lines[k + 1].replace(f",aoi{1000 + k},".encode(), b",aoi\xc9\xcf,")
        (tmp_path / "bad.csv").write_bytes(b"\n".join(lines))
        with pytest.raises(InputError, match="not UTF-8") as err:
            read_lade(tmp_path / "bad.csv", DataConfig())
        assert (err.value.row, err.value.column) == (k + 2, "aoi_id")


def test_bytes_that_are_not_utf8_opening_a_line_in_a_column_not_read_do_not_matter(
    tmp_path: Path,
) -> None:
    """The first column of a line, when marops does not read it (city, first here, in
    GBK), is not read either; in a first column it reads (order_id) such bytes are an
    error naming it."""
    rows = [row(str(1000 + i), lng=f"{121.40 + 0.001 * i:.4f}") for i in range(20)]
    columns = ("city", *(c for c in LADE_COLUMNS if c != "city"))
    text = write_csv(tmp_path / "d.csv", rows, columns=columns).read_bytes()
    plain = read_lade(tmp_path / "d.csv", DataConfig())
    (tmp_path / "gbk.csv").write_bytes(text.replace(b"Shanghai", "上海市".encode("gbk")))
    t = read_lade(tmp_path / "gbk.csv", DataConfig())
    assert list(t.order_id) == list(plain.order_id) and len(t) == 20
    lines = write_csv(tmp_path / "ids.csv", rows).read_bytes().split(b"\n")
    assert lines[3].startswith(b"1002,")
    lines[3] = b"\xc9\xcf" + lines[3]  # order_id, the first column
    (tmp_path / "bad.csv").write_bytes(b"\n".join(lines))
    with pytest.raises(InputError, match="not UTF-8") as err:
        read_lade(tmp_path / "bad.csv", DataConfig())
    assert (err.value.row, err.value.column) == (4, "order_id")


def test_a_name_that_is_not_utf8_of_a_column_not_read_does_not_matter(tmp_path: Path) -> None:
    """A header naming a column marops does not read in GBK (城市 for city, as a Chinese
    spreadsheet saves it) or Latin-1 (an extra column 'entrée'): the column is not read,
    nor its name, where the file was refused as not UTF-8 at row 1."""
    text = write_csv(tmp_path / "d.csv", CLEAN).read_bytes()
    header, rest = text.split(b"\n", 1)
    for name in ("城市".encode("gbk"), "entrée".encode("latin-1")):
        path = tmp_path / "named.csv"
        path.write_bytes(header.replace(b"city", name) + b"\n" + rest)
        t = read_lade(path, DataConfig())
        assert list(t.order_id) == ["1001", "1002", "1003"]
    path.write_bytes(header.replace(b"order_id", b"order_id\xe9") + b"\n" + rest)
    with pytest.raises(InputError, match="missing required column 'order_id'"):
        read_lade(path, DataConfig())


def test_a_file_name_that_is_not_utf8_reads(tmp_path: Path) -> None:
    """A name in another encoding (an archive's GBK names) is no reason to fail: pyarrow
    opened the path as UTF-8 and raised UnicodeEncodeError, a traceback."""
    plain = write_csv(tmp_path / "d.csv", CLEAN)
    want = read_lade(plain, DataConfig())
    gbk = os.fsdecode(b"\xc9\xcf\xba\xa3")  # "Shanghai" in GBK
    csv_path = tmp_path / f"{gbk}.csv"
    csv_path.write_bytes(plain.read_bytes())
    gz_path = tmp_path / f"{gbk}.csv.gz"
    gz_path.write_bytes(gzip.compress(plain.read_bytes()))
    pq_path = tmp_path / f"{gbk}.parquet"
    pq_path.write_bytes(_as_parquet(tmp_path, "p.parquet").read_bytes())
    for path in (csv_path, gz_path, pq_path):
        got = read_lade(path, DataConfig())
        np.testing.assert_array_equal(got.delivery_s, want.delivery_s)
        assert got.source.name == path.name


def test_weight_column(tmp_path: Path) -> None:
    cols = [*LADE_COLUMNS, "weight_kg"]
    rows = [dict(r, weight_kg=w) for r, w in zip(CLEAN, ["0.25", "1.5", "2"], strict=True)]
    t = read_lade(write_csv(tmp_path / "w.csv", rows, cols), DataConfig())
    np.testing.assert_allclose(t.weight_kg, [0.25, 1.5, 2.0], rtol=0, atol=0)
    rows[1]["weight_kg"] = "heavy"
    with pytest.raises(InputError) as err:
        read_lade(write_csv(tmp_path / "w.csv", rows, cols), DataConfig())
    assert (err.value.row, err.value.column) == (3, "weight_kg")


def test_bom_and_crlf(tmp_path: Path) -> None:
    path = write_csv(tmp_path / "d.csv", CLEAN)
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes().replace(b"\n", b"\r\n"))
    t = read_lade(path, DataConfig())
    assert list(t.order_id) == ["1001", "1002", "1003"]
    np.testing.assert_array_equal(t.row, [2, 3, 4])


def test_duplicates_need_every_key_equal(tmp_path: Path) -> None:
    base = CLEAN[0]
    rows = [
        base,
        CLEAN[1],
        dict(base, order_id="1999"),  # same times and place, other id: kept
        dict(base),  # duplicate (row 5)
        dict(base, lng="121.470"),  # same number written differently: duplicate
        dict(base, lat="31.2301"),  # other place: kept
        dict(CLEAN[1]),  # duplicate of row 3
    ]
    t = read_lade(write_csv(tmp_path / "d.csv", rows), DataConfig())
    assert t.report.dropped["duplicate"] == 3
    np.testing.assert_array_equal(t.row, [2, 3, 4, 7])
    assert_accounted(t)


def test_every_row_dropped(tmp_path: Path) -> None:
    rows = [row("1", lng="0"), row("2", acc="")]
    t = read_lade(write_csv(tmp_path / "d.csv", rows), DataConfig())
    assert len(t) == 0 and t.report.kept == 0 and t.report.n_dropped == 2
    assert t.order_id.shape == t.lng.shape == t.row.shape == (0,)
    assert t.days() == []


def test_ds_is_optional_and_may_be_empty_or_float(tmp_path: Path) -> None:
    """Other exporters drop ds, leave it empty, or write it as 820.0 after pandas."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from marops_cli.config import DataConfig
    from marops_cli.data.reader import read_lade

    base = {
        "order_id": ["1", "2", "3"],
        "lng": [121.47, 121.48, 121.49],
        "lat": [31.23, 31.24, 31.25],
        "accept_time": ["08-20 08:00:00"] * 3,
        "delivery_time": ["08-20 10:00:00"] * 3,
    }
    pq.write_table(pa.table(base), tmp_path / "no_ds.parquet")
    pq.write_table(pa.table(base | {"ds": [820.0, None, 820.0]}), tmp_path / "float_ds.parquet")
    for name in ("no_ds.parquet", "float_ds.parquet"):
        table = read_lade(tmp_path / name, DataConfig())
        assert len(table) == 3
        assert [d.isoformat() for d in table.days()] == ["2022-08-20"]


def test_a_ds_of_another_day_is_counted_not_dropped(tmp_path: Path) -> None:
    """A ds naming another day than the delivery time is kept (the delivery time's day
    is the request's) and counted in the report's line; an empty ds is no other day."""
    rows = [
        *CLEAN,  # 1003: accepted 08-19, delivered and ds 08-21
        row("1004", ds="819"),  # delivered 08-20
        row("1005", ds="20220821"),
        row("1006", ds=""),
        row("1007", acc="", ds="101"),  # dropped: not counted again
    ]
    t = read_lade(write_csv(tmp_path / "d.csv", rows), DataConfig())
    assert len(t) == 6 and t.report.ds_other_day == 2
    assert t.report.to_dict()["ds_other_day"] == 2
    assert t.report.describe("d.csv") == (
        "d.csv: 7 rows read, 6 kept, 1 dropped (1 missing time); --strict makes these "
        "errors; 2 kept rows have a ds of another day than the delivery time, whose day "
        "is used"
    )
    assert [d.isoformat() for d in t.days()] == ["2022-08-20", "2022-08-21"]
    clean = read_lade(write_csv(tmp_path / "c.csv", CLEAN), DataConfig()).report
    assert clean.ds_other_day == 0 and "ds_other_day" not in clean.to_dict()
    assert clean.describe("c.csv") == "c.csv: 3 rows read, none dropped"


def test_a_ds_without_its_year_is_a_day_of_the_full_delivery_time_year(tmp_path: Path) -> None:
    """Beside full times, ``ds`` MMDD names a day of its row's delivery year: 229 beside
    2024-02-29 is that day (it was refused as no day of --year 2022), and over the new
    year 101 beside 2023-01-01 is no other day (every such row was counted as one)."""
    rows = [
        row("1", acc="2024-02-29 08:00:00", dlv="2024-02-29 10:00:00", ds="229"),
        row("2", acc="2022-12-31 23:10:00", dlv="2023-01-01 10:20:00", ds="101"),
        row("3", acc="2022-12-31 08:00:00", dlv="2022-12-31 10:00:00", ds="1231"),
        row("4", acc="2023-01-01 08:00:00", dlv="2023-01-01 10:00:00", ds="1231"),
    ]
    t = read_lade(write_csv(tmp_path / "d.csv", rows), DataConfig())
    assert len(t) == 4 and t.report.ds_other_day == 1  # row 4's ds is 2023-12-31
    bad = [row("1", acc="2023-02-28 08:00:00", dlv="2023-02-28 10:00:00", ds="229")]
    with pytest.raises(InputError, match=r"column 'ds': expected a date MMDD in 2023, got '229'"):
        read_lade(write_csv(tmp_path / "b.csv", bad), DataConfig(year=2024))


class _Said:
    """What a run says: its messages and warnings, as drop_report hands them out."""

    def __init__(self) -> None:
        self.messages: list[str] = []
        self.warnings: list[str] = []

    def message(self, text: str) -> None:
        self.messages.append(text)

    def warning(self, text: str) -> None:
        self.warnings.append(text)


def test_an_mm_dd_export_over_the_new_year_is_warned_of(tmp_path: Path) -> None:
    """MM-DD times take one year: an export from 30 December to 1 January reads its 1
    January as January of that year, before December, and drops an order accepted on
    31 December and delivered on 1 January as delivered before it was accepted. The run
    says so and what to write instead; the same rows with full dates, and an export of
    one year's January to December without such a gap, read without it."""
    from marops_cli.app.messages import drop_report

    def warned(rows: list[dict[str, str]]) -> list[str]:
        table = read_lade(write_csv(tmp_path / "d.csv", rows), DataConfig())
        said = _Said()
        drop_report(said, table, "d.csv")  # type: ignore[arg-type]
        return said.warnings

    mmdd = [
        row("1", acc="12-30 08:00:00", dlv="12-30 10:00:00", ds="1230"),
        row("2", acc="12-31 08:00:00", dlv="12-31 10:00:00", ds="1231"),
        row("3", acc="12-31 21:00:00", dlv="01-01 10:00:00", ds="101"),
        row("4", acc="01-01 08:00:00", dlv="01-01 11:00:00", ds="101"),
    ]
    (said,) = warned(mmdd)
    assert said.startswith("d.csv: its days are 2022-01-01, 2022-12-30..2022-12-31, ")
    assert "MM-DD times take one year" in said and " 2022), so its January days" in said
    assert "YYYY-MM-DD HH:MM:SS" in said
    full = [
        {**r, "accept_time": y + r["accept_time"], "delivery_time": z + r["delivery_time"]}
        for r, y, z in zip(
            mmdd,
            ["2022-", "2022-", "2022-", "2023-"],
            ["2022-", "2022-", "2023-", "2023-"],
            strict=True,
        )
    ]
    assert warned(full) == []
    year = [
        row(str(m), acc=f"{m:02d}-10 08:00:00", dlv=f"{m:02d}-10 10:00:00", ds=f"{m}10")
        for m in range(1, 13)
    ]
    assert warned(year) == []


def test_weights_in_grams_are_warned_of(tmp_path: Path) -> None:
    """A weight_kg column written in grams (a median of hundreds) reads as parcels no
    drone lifts, which the run said only hub by hub: it warns once, naming the median and
    the remedy; weights in kg, heavy ones among them, read without it."""
    from marops_cli.app.messages import drop_report

    def warned(weights: list[str]) -> list[str]:
        rows = [{**r, "weight_kg": w} for r, w in zip(CLEAN, weights, strict=True)]
        table = read_lade(
            write_csv(tmp_path / "d.csv", rows, (*LADE_COLUMNS, "weight_kg")), DataConfig()
        )
        said = _Said()
        drop_report(said, table, "d.csv")  # type: ignore[arg-type]
        return said.warnings

    assert warned(["850", "1200", "430"]) == [
        "d.csv: its weight_kg column's median parcel weighs 850 kg: weights are read in kg; "
        "if the column holds grams, divide it by 1,000"
    ]
    assert warned(["0.85", "1.2", "30"]) == []


def test_kept_rows_that_repeat_an_order_id_are_warned_of(tmp_path: Path) -> None:
    """A row repeating an order id with other times is kept (only exact repeats are
    dropped) and planned as an order of its own: the run says how many there are."""
    from marops_cli.app.messages import drop_report

    again = row("1002", "121.4810", "31.2400", "08-20 09:40:00", "08-20 11:30:00")
    for rows, warned in ((CLEAN, []), ([*CLEAN, again, CLEAN[0]], ["1 kept row repeats"])):
        table = read_lade(write_csv(tmp_path / "d.csv", rows), DataConfig())
        said = _Said()
        drop_report(said, table, "d.csv")  # type: ignore[arg-type]
        assert [w[len("d.csv: ") :][:18] for w in said.warnings] == warned
        assert len(said.messages) == 1


@pytest.mark.parametrize("header", ["Order_ID ", " order-id", '"ORDER ID"'])
def test_a_column_named_but_for_case_or_spaces_is_named_in_the_error(
    tmp_path: Path, header: str
) -> None:
    """A header that writes order_id otherwise (case, spaces, a hyphen) was refused as a
    missing column with no word of the near match."""
    path = write_csv(tmp_path / "d.csv", CLEAN)
    text = path.read_text(encoding="utf-8").replace("order_id", header, 1)
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_lade(path, DataConfig())
    near = header.strip().strip('"')  # the reader trims the header's names
    assert f"the header has {near!r}: name it 'order_id' (lower case, no spaces)" in str(err.value)


def test_a_zero_coordinate_is_a_place_by_the_prime_meridian_or_the_equator(
    tmp_path: Path,
) -> None:
    """0 marks a missing coordinate where the city lies away from it (Shanghai's rows:
    lng 0 or lat 0 dropped as bad coordinates); by the prime meridian (London, rounded
    to 2 decimals: a strip of its orders at lng 0.00) or the equator (Quito) 0 is a
    place, and those rows are kept, while a value out of range is still dropped."""
    shanghai = [*CLEAN, row("1004", lng="0"), row("1005", lat="0")]
    t = read_lade(write_csv(tmp_path / "sh.csv", shanghai), DataConfig())
    assert len(t) == 3 and t.report.to_dict()["dropped"]["bad_coordinates"] == 2
    london = [
        row(str(2000 + k), lng=f"{x:.2f}", lat="51.48") for k, x in enumerate((-0.02, 0, 0.01))
    ]
    quito = [
        row(str(3000 + k), lng="-78.47", lat=f"{y:.2f}") for k, y in enumerate((-0.22, 0, 0.05))
    ]
    for name, rows in (("london.csv", london), ("quito.csv", quito)):
        kept = read_lade(write_csv(tmp_path / name, [*rows, row("9", lat="95")]), DataConfig())
        assert len(kept) == 3 and kept.report.to_dict()["dropped"]["bad_coordinates"] == 1
    assert 0.0 in read_lade(write_csv(tmp_path / "l.csv", london), DataConfig()).lng


def test_lng_and_lat_swapped_are_suggested_with_the_bad_coordinates(tmp_path: Path) -> None:
    """lng and lat written the other way round (31, 121) dropped every row as bad
    coordinates with no hint; the report now says how many would be good swapped."""
    swapped = [{**r, "lng": r["lat"], "lat": r["lng"]} for r in CLEAN]
    bad = row("1004", lng="0", lat="0")  # bad either way
    t = read_lade(write_csv(tmp_path / "s.csv", [*swapped, bad]), DataConfig())
    assert t.report.swapped_coordinates == 3
    assert t.report.to_dict()["swapped_coordinates"] == 3
    assert "4 bad coordinates (3 good with lng and lat swapped: are the columns swapped?)" in (
        t.report.describe("s.csv")
    )
    all_swapped = read_lade(write_csv(tmp_path / "a.csv", swapped), DataConfig())
    assert "3 bad coordinates (all good with lng and lat swapped" in all_swapped.report.reasons()
    clean = read_lade(write_csv(tmp_path / "c.csv", CLEAN), DataConfig()).report
    assert clean.swapped_coordinates == 0 and "swapped_coordinates" not in clean.to_dict()


def test_orders_accepted_in_december_and_delivered_in_january_are_named(tmp_path: Path) -> None:
    """An export of January's first days in MM-DD times: an order accepted on 31
    December reads as accepted after its delivery (one year for both), and is dropped;
    the report says how many such rows, and what to write, where it said only
    'delivery before accept' (the new-year warning needs the file's days to hold a
    December)."""
    rows = [
        row("1", acc="01-01 08:00:00", dlv="01-01 10:00:00", ds="101"),
        row("2", acc="12-31 20:00:00", dlv="01-01 10:00:00", ds="101"),
        row("3", acc="12-30 20:00:00", dlv="01-02 10:00:00", ds="102"),
        row("4", acc="01-02 12:00:00", dlv="01-02 11:00:00", ds="102"),  # no year's mistake
    ]
    t = read_lade(write_csv(tmp_path / "jan.csv", rows), DataConfig())
    assert t.report.dropped["delivery_before_accept"] == 3 and t.report.over_new_year == 2
    assert t.report.to_dict()["over_new_year"] == 2
    assert (
        "3 delivery before accept (2 accepted in December, delivered in January of one year: "
        "if the export runs over the new year, write its times as YYYY-MM-DD HH:MM:SS)"
    ) in t.report.describe("jan.csv")
    full = [dict(r, accept_time=f"2022-{r['accept_time']}") for r in rows[1:3]]
    full = [dict(r, delivery_time=f"2023-{r['delivery_time']}") for r in full]
    clean = read_lade(write_csv(tmp_path / "full.csv", full), DataConfig()).report
    assert clean.over_new_year == 0 and "over_new_year" not in clean.to_dict()
    assert clean.describe("full.csv") == "full.csv: 2 rows read, none dropped"


def test_coordinates_written_with_a_decimal_comma_are_named(tmp_path: Path) -> None:
    """A spreadsheet of a locale that writes 121,47 saves coordinates so (quoted in a
    comma-separated file): every row is dropped as bad coordinates, and the report says
    how many were written with a decimal comma, where it said only 'bad coordinates'."""
    rows = [{**r, "lng": f'"{r["lng"].replace(".", ",")}"'} for r in CLEAN]
    bad = row("1004", lng="x")  # bad, no comma
    t = read_lade(
        write_csv(tmp_path / "c.csv", [*rows, CLEAN[0] | {"order_id": "9"}, bad]), DataConfig()
    )
    assert len(t) == 1 and t.report.decimal_comma == 3
    assert t.report.to_dict()["decimal_comma"] == 3
    assert (
        "4 bad coordinates (3 written with a decimal comma: write the numbers with a decimal "
        "point)" in t.report.describe("c.csv")
    )
    swapped = [{**r, "lng": r["lat"], "lat": f'"{r["lng"].replace(".", ",")}"'} for r in CLEAN]
    both = read_lade(write_csv(tmp_path / "b.csv", swapped), DataConfig()).report
    assert "(3 good with lng and lat swapped" not in both.reasons()
    assert "3 bad coordinates (all written with a decimal comma" in both.reasons()
    clean = read_lade(write_csv(tmp_path / "k.csv", CLEAN), DataConfig()).report
    assert clean.decimal_comma == 0 and "decimal_comma" not in clean.to_dict()
