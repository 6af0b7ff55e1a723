"""report.html of folders holding what a run rarely writes: names that look like HTML or
are not UTF-8, a damaged day among several, a folder of one's own among the days,
hundreds of folders, one of a thing."""

from __future__ import annotations

import html
import json
import os
import shutil
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.csv as pacsv

from marops_cli.cli.app import app

from .conftest import figure, invoke, rewrite_parquet, runner

# An order id, a drone type or a method name from a file: plotly reads a figure's strings
# as HTML, so unescaped this would be drawn as a link and in bold.
NAME = "<a href='https://e.x/'>x</a><b>&amp;</b>"
SHOWN = html.escape(NAME, quote=False)


def _strings(obj: Any) -> Iterator[str]:
    if isinstance(obj, str):
        yield obj
    elif isinstance(obj, dict):
        for v in obj.values():
            yield from _strings(v)
    elif isinstance(obj, list | tuple):
        for v in obj:
            yield from _strings(v)


def _figure_strings(page: Path, div_id: str) -> list[str]:
    return list(_strings(figure(page.read_text(encoding="utf-8"), div_id)))


def _no_markup_but_ours(strings: list[str]) -> None:
    assert any(SHOWN in s for s in strings)
    assert not any(NAME in s or "<a " in s or "<b>" in s for s in strings)


def test_names_from_a_days_files_are_text_on_its_figures(day_run: Path, tmp_path: Path) -> None:
    copy = tmp_path / "copy"
    shutil.copytree(day_run, copy)
    rewrite_parquet(copy / "stops.parquet", "order_id", lambda v: v if v is None else NAME + v)
    rewrite_parquet(copy / "routes.parquet", "drone_type", lambda v: NAME)
    invoke("report", copy, "--quiet")
    strings = _figure_strings(copy / "report.html", "map")
    _no_markup_but_ours(strings)
    assert any(s.startswith(f"order {SHOWN}") for s in strings)  # a stop's hover
    assert any(s.endswith(f"({SHOWN})") for s in strings)  # a drone's legend entry


def test_names_from_an_evaluations_files_are_text_on_its_figures(
    evaluation_run: Path, tmp_path: Path
) -> None:
    copy = tmp_path / "ev"
    shutil.copytree(evaluation_run, copy)
    for name in ("summary.csv", "paired.csv"):
        table = pacsv.read_csv(copy / name)
        for column in ("method", "metric"):
            if column in table.column_names:
                i = table.schema.get_field_index(column)
                new = pa.array([NAME + v for v in table.column(column).to_pylist()])
                table = table.set_column(i, column, new)
        pacsv.write_csv(table, copy / name)
    rewrite_parquet(copy / "results.parquet", "method", lambda v: NAME + v)
    rewrite_parquet(copy / "results.parquet", "day", lambda v: NAME + str(v))
    invoke("report", copy, "--quiet", "--force")  # the tables edited are no more marops's
    for div_id in ("paired", "sweep-alpha", "days"):
        _no_markup_but_ours(_figure_strings(copy / "report.html", div_id))


def test_day_names_are_text_on_the_chart_over_the_days(tmp_path: Path) -> None:
    out = tmp_path / "days"
    out.mkdir()
    doc = {"days": [{"day": NAME, "method": "stay", "delivered_share": 0.5}], "total": {}}
    (out / "metrics.json").write_text(json.dumps(doc))
    invoke("report", out, "--quiet")
    _no_markup_but_ours(_figure_strings(out / "report.html", "days"))


def test_a_damaged_day_among_several_leaves_every_page_as_it_was(
    day_run: Path, tmp_path: Path
) -> None:
    """The pages of a several-day folder appear together or not at all: the second
    day's damaged metrics stop the report before the first day's page is in place."""
    out = tmp_path / "days"
    for day in ("2022-08-11", "2022-08-12"):
        shutil.copytree(day_run, out / day)
        (out / day / "report.html").unlink()
    (out / "2022-08-12" / "metrics.json").write_text("{")
    doc = json.loads((day_run / "metrics.json").read_text())
    (out / "metrics.json").write_text(json.dumps({**doc, "total": {"delivered": 1}}))
    res = runner.invoke(app, ["report", str(out)])
    assert res.exit_code == 2 and "2022-08-12" in res.stderr, res.output
    assert sorted(p.name for p in out.rglob("*") if p.name.startswith(("report", "."))) == [
        ".marops-files.json",
        ".marops-files.json",
    ]


def test_folder_names_that_are_not_utf8_are_shown_and_linked(tmp_path: Path) -> None:
    """Linux names a folder with any bytes: the page names it escaped (as the JSON
    outputs do), and the link to a day holds its bytes, percent-encoded."""
    out = tmp_path / "days\udcff"  # the byte 0xFF, as Python holds it
    day = "d\udcfe"
    (out / day).mkdir(parents=True)
    (out / day / "metrics.json").write_text('{"total": {"delivered": 1}}')
    doc = {"days": [{"day": day, "method": "stay"}], "total": {"delivered": 1}}
    (out / "metrics.json").write_text(json.dumps(doc))
    res = runner.invoke(app, ["report", str(out), "--quiet"])
    assert res.exit_code == 0, res.output
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "<title>marops: 1 day — days\\udcff</title>" in page
    assert 'href="d%FE/report.html"' in page


def test_a_folder_of_ones_own_among_the_days_is_left_alone(day_run: Path, tmp_path: Path) -> None:
    """A folder among the days with a metrics.json and a report.html of another tool:
    the days get their pages, that folder keeps its files (no --force asked for)."""
    out = tmp_path / "days"
    shutil.copytree(day_run, out / "2022-08-11")
    doc = json.loads((day_run / "metrics.json").read_text())
    (out / "metrics.json").write_text(json.dumps({**doc, "total": {"delivered": 1}}))
    mine = out / "notes"
    mine.mkdir()
    (mine / "metrics.json").write_text('{"accuracy": 0.9}')
    (mine / "report.html").write_text("my page")
    res = runner.invoke(app, ["report", str(out)])
    assert res.exit_code == 0, res.output
    assert (out / "report.html").is_file() and (out / "2022-08-11" / "report.html").is_file()
    assert sorted(p.name for p in mine.iterdir()) == ["metrics.json", "report.html"]
    assert (mine / "report.html").read_text() == "my page"
    assert "notes" not in res.output


def test_a_day_folder_that_is_a_link_gets_no_page_through_it(day_run: Path, tmp_path: Path) -> None:
    """A day among the days that is a link to another run's day: refused naming it, so
    no page is written into the other run's folder; a link to a folder of one's own (no
    marops outputs) is left alone."""
    other = tmp_path / "other" / "2022-08-11"
    shutil.copytree(day_run, other)
    (other / "report.html").unlink(missing_ok=True)
    out = tmp_path / "days"
    out.mkdir()
    (out / "2022-08-11").symlink_to(other)
    doc = json.loads((day_run / "metrics.json").read_text())
    (out / "metrics.json").write_text(json.dumps({**doc, "total": {"delivered": 1}}))
    res = runner.invoke(app, ["report", str(out)])
    assert res.exit_code == 2, res.output
    assert "is a link to a day's or hub's outputs" in res.output
    assert not (other / "report.html").exists() and not (out / "report.html").exists()
    (out / "2022-08-11").unlink()
    shutil.copytree(day_run, out / "2022-08-11")
    mine = tmp_path / "notes"
    mine.mkdir()
    (mine / "metrics.json").write_text('{"accuracy": 0.9}')
    (out / "notes").symlink_to(mine)
    res = runner.invoke(app, ["report", str(out), "--force"])
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in mine.iterdir()) == ["metrics.json"]


def test_hundreds_of_pages_are_put_in_place_within_few_open_files(tmp_path: Path) -> None:
    """A city's month is hundreds of folders: their pages are put in place a folder at
    a time, not with every folder held open at once (the usual limit is 1024 files)."""
    import resource

    out = tmp_path / "city"
    doc = json.dumps({"days": [], "total": {"delivered": 1}})
    for sub in ("", *(f"hub-{i}" for i in range(200))):
        (out / sub).mkdir(parents=True, exist_ok=True)
        (out / sub / "metrics.json").write_text(doc)
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    in_use = len(os.listdir("/proc/self/fd"))
    resource.setrlimit(resource.RLIMIT_NOFILE, (in_use + 100, hard))
    try:
        res = runner.invoke(app, ["report", str(out), "--quiet"])
    finally:
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
    assert res.exit_code == 0, res.output
    assert len(list(out.rglob("report.html"))) == 201


def test_one_of_a_thing_is_said_in_the_singular(evaluation_run: Path) -> None:
    from marops_cli.report.day import _title
    from marops_cli.report.folder import RouteFiles

    one = RouteFiles([], [{"drone": 0, "day": "2022-08-11", "hub": 0}], {"method": "stay"})
    assert _title(one, None) == "marops: 2022-08-11 — stay, 1 drone"
    page = (evaluation_run / "report.html").read_text(encoding="utf-8")
    assert "1 day (2022-08-11), 1 repeat;" in page


def _opened_then_closed(fifo: Path, seconds: float) -> threading.Thread:
    """A writer that, within ``seconds``, opens the pipe ``fifo`` once someone reads it
    and closes it at once (so a reader blocked on it ends), else gives up."""

    def write() -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            try:
                fd = os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)
            except OSError:  # no reader yet
                time.sleep(0.05)
                continue
            os.close(fd)
            return

    thread = threading.Thread(target=write, daemon=True)
    thread.start()
    return thread


def test_a_pipe_or_device_in_place_of_an_output_is_refused_unread(
    day_run: Path, tmp_path: Path
) -> None:
    """A pipe nobody writes to would block the report for ever (Arrow's open does not
    give way to SIGTERM), and a device such as /dev/zero would fill the memory: neither
    is opened, and the line names the file."""
    copy = tmp_path / "copy"
    shutil.copytree(day_run, copy)
    (copy / "report.html").unlink()
    stops = copy / "stops.parquet"
    stops.unlink()
    os.mkfifo(stops)
    writer = _opened_then_closed(stops, 5.0)  # the old reader would otherwise wait for ever
    res = runner.invoke(app, ["report", str(copy)])
    writer.join()
    assert res.exit_code == 2, res.output
    assert "stops.parquet: is not a regular file" in res.stderr, res.stderr
    assert not (copy / "report.html").exists()
