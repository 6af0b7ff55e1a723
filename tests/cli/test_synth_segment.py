"""`marops synth` and `marops segment` through the CLI, checked against the library."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow.csv as pv
import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.config import DataConfig, SegmentConfig
from marops_cli.data.prepare import study_frame
from marops_cli.data.reader import read_lade
from marops_cli.segment import segment_points
from marops_cli.segment.run import history_points

runner = CliRunner()


def test_synth_twice_same_bytes_and_every_row_accounted(tmp_path: Path) -> None:
    paths = []
    for k in range(2):
        p = tmp_path / f"s{k}.csv"
        res = runner.invoke(app, ["synth", "--days", "30", "--seed", "1", "--out", str(p)])
        assert res.exit_code == 0, res.output
        paths.append(p)
    assert paths[0].read_bytes() == paths[1].read_bytes()
    n_rows = pv.read_csv(paths[0]).num_rows
    table = read_lade(paths[0], DataConfig())
    rep = table.report
    assert rep.total == n_rows
    assert rep.kept + sum(rep.dropped.values()) == rep.total
    assert rep.kept == len(table)
    assert {"bad_coordinates", "duplicate", "delivery_before_accept"} <= {
        k for k, v in rep.dropped.items() if v > 0
    }
    assert len(table.days()) == 30


@pytest.mark.parametrize("value", ["inf", "nan", "1e9", "1e12", "0"])
def test_synth_refuses_orders_per_day_out_of_range(
    tmp_path: Path, fails_cleanly, value: str
) -> None:
    """Beyond a million orders a day the generator runs out of courier ids: one line
    naming the option and its range, no file."""
    args = ["synth", "--days", "1", "--orders-per-day", value, "--out", str(tmp_path / "s.csv")]
    line = fails_cleanly(args, tmp_path, "invalid option --orders-per-day: ")
    assert "(expected 0 < orders-per-day ≤ 1e6)" in line


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--seed", "4294967296"], "invalid option --seed: "),
        (["--seed", "-1"], "invalid option --seed: "),
        (["--start", "2022-12-30", "--days", "3"], "run past the end of its year"),
        # Beyond any calendar: the range is checked before the last day is computed.
        (["--days", "100000000"], "(expected 1 ≤ days ≤ 366)"),
        # A year the reader's --year refuses: the file could not be read back.
        (["--start", "1969-12-31"], "invalid option --start: 1969-12-31 is in a year"),
        (["--start", "9999-12-31"], "(1970 ≤ year ≤ 2100, --year)"),
        # synth has no --year: a February 29 without its year asks for the year written.
        (["--start", "0229"], "of days without one; write a leap year's, 2024-02-29"),
    ],
    ids=["seed-big", "seed-negative", "new-year", "days-beyond-calendar", "1969", "9999", "0229"],
)
def test_synth_refuses_seeds_and_spans_it_cannot_make(
    tmp_path: Path, fails_cleanly, args: list[str], says: str
) -> None:
    line = fails_cleanly(["synth", *args, "--out", str(tmp_path / "s.csv")], tmp_path, says)
    assert "seed" not in args[0] or "(expected 0 ≤ seed ≤ 4294967295)" in line


def test_synth_refuses_a_file_larger_than_the_memory_before_any_work(
    tmp_path: Path, fails_cleanly, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The generator holds the whole table: a request the memory cannot hold is one line
    naming the options and both sizes, not a run the system kills half-way."""
    import marops_cli.app.synth as app_synth

    monkeypatch.setattr(app_synth, "available_memory", lambda: 10**9)
    args = ["synth", "--days", "10", "--orders-per-day", "200000"]
    line = fails_cleanly([*args, "--out", str(tmp_path / "s.csv")], tmp_path, "--orders-per-day")
    # 0.2 GB + 0.7 kB × 1.1 × 2,000,000 rows
    assert "10 days of 200,000 orders need about 1.7 GB of memory" in line
    assert "1.0 GB is available" in line
    small = tmp_path / "small.csv"
    res = runner.invoke(app, ["synth", "--days", "2", "--out", str(small)])
    assert res.exit_code == 0, res.output
    assert small.is_file()


def test_out_of_memory_is_one_line_and_leaves_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import marops_cli.data.synth as data_synth

    def write(*_a: object, **_k: object) -> None:
        raise MemoryError

    monkeypatch.setattr(data_synth, "write", write)
    res = runner.invoke(app, ["synth", "--days", "1", "--out", str(tmp_path / "s.csv")])
    assert res.exit_code == 1
    assert res.stderr.strip().splitlines() == [
        "marops: error: out of memory during synth: ask for less at once (fewer days, a "
        "smaller file or fleet) or run it on a machine with more memory"
    ]
    assert list(tmp_path.iterdir()) == []


def test_synth_parquet_reads_like_csv(tmp_path: Path) -> None:
    for fmt in ("csv", "parquet"):
        res = runner.invoke(
            app,
            [
                "synth",
                "--days",
                "2",
                "--seed",
                "4",
                "--format",
                fmt,
                "--out",
                str(tmp_path / f"s.{fmt}"),
            ],
        )
        assert res.exit_code == 0, res.output
    a = read_lade(tmp_path / "s.csv", DataConfig())
    b = read_lade(tmp_path / "s.parquet", DataConfig())
    assert a.report.to_dict() == b.report.to_dict()
    np.testing.assert_array_equal(a.order_id, b.order_id)
    np.testing.assert_allclose(a.lng, b.lng, atol=1e-9)


def test_segment_cli_equals_library(example_csv: Path, tmp_path: Path) -> None:
    out = tmp_path / "depots.json"
    gj = tmp_path / "depots.geojson"  # beside --out
    png = tmp_path / "depots.png"
    res = runner.invoke(
        app,
        [
            "segment",
            str(example_csv),
            "--dates",
            "0801..0810",
            "--seed",
            "2",
            "--out",
            str(out),
            "--geojson",
            "--plot",
        ],
    )
    assert res.exit_code == 0, res.output
    doc = json.loads(out.read_text())
    table = read_lade(example_csv, DataConfig())
    days = table.days()[:10]
    frame = study_frame(table, DataConfig(), days)
    pts, _ = history_points(table, frame, days)
    dep = segment_points(pts[:, 0], pts[:, 1], frame, SegmentConfig(seed=2))
    np.testing.assert_allclose([[d["x_m"], d["y_m"]] for d in doc["depots"]], dep.xy, atol=1e-3)
    assert doc["candidates"] == {str(i): dep.candidates[i].tolist() for i in range(16)}
    assert doc["meta"]["input"]["name"] == "shanghai_synth.csv"
    assert doc["meta"]["rows"]["total"] == table.report.total
    assert json.loads(gj.read_text())["type"] == "FeatureCollection"
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert sum(d["n_history"] for d in doc["depots"]) == pts.shape[0]


def test_synth_csv_gz_is_gzip_and_reads_back(tmp_path: Path) -> None:
    """``--out X.csv.gz`` writes gzipped CSV (the same bytes for the same seed), which the
    reader, pandas and pyarrow read back as the plain CSV's rows."""
    import gzip

    import pandas as pd

    for name in ("s.csv", "s.csv.gz", "again.csv.gz"):
        args = ["synth", "--days", "2", "--seed", "4", "--out", str(tmp_path / name)]
        res = runner.invoke(app, args)
        assert res.exit_code == 0, res.output
    gz = tmp_path / "s.csv.gz"
    assert gz.read_bytes()[:2] == b"\x1f\x8b"
    assert gz.read_bytes() == (tmp_path / "again.csv.gz").read_bytes()
    assert gzip.decompress(gz.read_bytes()) == (tmp_path / "s.csv").read_bytes()
    assert len(pd.read_csv(gz)) == pv.read_csv(tmp_path / "s.csv").num_rows
    a = read_lade(tmp_path / "s.csv", DataConfig())
    b = read_lade(gz, DataConfig())
    assert a.report.to_dict() == b.report.to_dict()
    np.testing.assert_array_equal(a.order_id, b.order_id)
    np.testing.assert_array_equal(a.delivery_s, b.delivery_s)


@pytest.mark.parametrize("name", ["s.csv.bz2", "s.xz", "s.zip"])
def test_synth_refuses_a_compression_it_does_not_write(
    tmp_path: Path, fails_cleanly, name: str
) -> None:
    """Plain CSV under a .bz2 name (what it wrote before) reads back as a broken file."""
    out = str(tmp_path / name)
    fails_cleanly(
        ["synth", "--days", "1", "--out", out], tmp_path, "invalid option --out", ".csv.gz"
    )


@pytest.mark.parametrize(
    "args", [["--out", "s.parquet.gz"], ["--format", "parquet", "--out", "s.gz"]]
)
def test_synth_refuses_gzipped_parquet(tmp_path: Path, fails_cleanly, args: list[str]) -> None:
    """The reader takes a gzipped file for CSV: Parquet under .gz is refused, naming --out."""
    args = [*args[:-1], str(tmp_path / args[-1])]
    fails_cleanly(["synth", "--days", "1", *args], tmp_path, "invalid option --out", ".csv.gz")


@pytest.mark.parametrize("name", ["s.parquet", "s.PQ"])
def test_synth_refuses_csv_under_a_parquet_name(tmp_path: Path, fails_cleanly, name: str) -> None:
    """--format csv into a .parquet file wrote CSV that the reader refused as a broken
    Parquet file: refused up front, naming --format."""
    out = str(tmp_path / name)
    args = ["synth", "--days", "1", "--format", "csv", "--out", out]
    fails_cleanly(args, tmp_path, "invalid option --format", ".csv")


@pytest.mark.parametrize(
    "extra",
    [[], ["--hubs", "auto"], ["--center", "121.47,31.23"]],
    ids=["kmeans", "hubs", "center"],
)
def test_segment_of_a_file_whose_rows_are_all_dropped_says_why(
    tmp_path: Path, fails_cleanly, extra: list[str]
) -> None:
    """Without --dates, a file none of whose rows can be used gets the line --dates gives
    (how many rows, dropped for what), not "no requests to place a study area on"."""
    header = "order_id,lng,lat,accept_time,delivery_time"
    rows = [f"{i},31.23,121.47,08-11 08:00:00,08-11 10:00:00" for i in range(5)]  # swapped
    data = tmp_path / "swapped.csv"
    data.write_text("\n".join([header, *rows]) + "\n", encoding="utf-8")
    args = ["segment", str(data), *extra, "--out", str(tmp_path / "out" / "d.json")]
    fails_cleanly(
        args,
        tmp_path,
        "swapped.csv: none of its 5 rows can be used (5 bad coordinates (all good with lng "
        "and lat swapped: are the columns swapped?))",
    )


def test_segment_of_a_file_named_in_another_encoding_writes_its_name_escaped(
    example_csv: Path, tmp_path: Path
) -> None:
    """depots.json records the input's name; a name that is not UTF-8 is written as JSON
    escapes (\\udcc9...) that read back as the same name, not a UnicodeEncodeError."""
    import json
    import os

    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    name = os.fsdecode(b"\xc9\xcf\xba\xa3.csv")
    data = tmp_path / name
    data.write_bytes(example_csv.read_bytes())
    out = tmp_path / "depots.json"
    res = CliRunner().invoke(
        app, ["segment", str(data), "--dates", "0801..0810", "--out", str(out)]
    )
    assert res.exit_code == 0, res.output
    assert json.loads(out.read_text(encoding="utf-8"))["meta"]["input"]["name"] == name


def test_one_depot_reads_one_depot(example_csv: Path, tmp_path: Path) -> None:
    res = runner.invoke(
        app, ["segment", str(example_csv), "--n-depots", "1", "--out", str(tmp_path / "d.json")]
    )
    assert res.exit_code == 0, res.output
    assert "1 depot around" in " ".join(res.output.split())


def test_segmentation_has_its_own_word_and_the_former_one_still_works(
    example_csv: Path, tmp_path: Path
) -> None:
    """``--method`` names a run method everywhere; segment's areas are ``--segmentation``.
    The former ``segment --method`` (hidden) and ``segment(method=)`` still give the same
    depots, with a note; both at once is refused."""
    import warnings

    from marops_cli import api as marops

    args = ["segment", str(example_csv), "--dates", "0801..0802", "--n-depots", "4"]
    docs = []
    for flag in ("--segmentation", "--method"):
        out = tmp_path / f"{flag[2:]}.json"
        res = runner.invoke(app, [*args, flag, "squares", "--out", str(out)])
        assert res.exit_code == 0, res.output
        assert ("is now --segmentation" in res.output) == (flag == "--method")
        docs.append(json.loads(out.read_text()))
    assert docs[0]["method"] == "squares" and docs[0] == docs[1]
    res = runner.invoke(
        app,
        [*args, "--segmentation", "squares", "--method", "kmeans", "--out", str(tmp_path / "x")],
    )
    assert res.exit_code == 2 and "--segmentation alone" in res.output
    with pytest.warns(DeprecationWarning, match="segmentation="):
        doc = marops.segment(example_csv, dates="0801..0802", n_depots=4, method="squares")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert (
            marops.segment(example_csv, dates="0801..0802", n_depots=4, segmentation="squares")
            == doc
        )
    assert doc["method"] == "squares"
