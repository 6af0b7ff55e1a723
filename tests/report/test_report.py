"""report.html (docs/report.md): what the page of a day, a window, several days and an
evaluation holds, read back from the HTML; ``marops report DIR``; the missing extra."""

from __future__ import annotations

import json
import re
import shutil
import sys
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from marops_cli.cli.app import app
from marops_cli.report.basemap import TILE_HOST

from .conftest import figure, invoke, rewrite_parquet, runner


def _flown(routes: list[dict]) -> list[dict]:
    return [r for r in routes if r["n_parcels"] > 0 or r["start_depot"] != r["end_depot"]]


def _shown(trace: dict, step: dict) -> bool:
    """Whether the map's slider at ``step`` shows ``trace``, as the page's script
    (WINDOW_SLIDER_SCRIPT) works it out: every trace but the routes of other windows."""
    route = re.match(r"route-w(\d+)-d", trace.get("uid", ""))
    return route is None or step["value"] in ("all", route[1])


def test_day_report_draws_one_line_per_route_the_depots_and_the_metrics(day_run: Path) -> None:
    html = (day_run / "report.html").read_text(encoding="utf-8")
    routes = pq.read_table(day_run / "routes.parquet").to_pylist()
    flown = _flown(routes)
    assert flown, "the small day flies routes"
    data, layout = figure(html, "map")
    lines = [t for t in data if t.get("uid", "").startswith("route-")]
    assert sorted(t["uid"] for t in lines) == sorted(
        f"route-w{r['window']}-d{r['drone']}" for r in flown
    )
    stops = pq.read_table(day_run / "stops.parquet").to_pylist()
    for t in lines:  # each line runs through its route's stops, in order
        w, d = (int(p[1:]) for p in t["uid"].split("-")[1:])
        mine = sorted(
            (s for s in stops if (s["window"], s["drone"]) == (w, d)), key=lambda s: s["seq"]
        )
        assert t["x"] == [s["lng"] for s in mine]
        assert len(t["text"]) == len(mine)
        customer = next(i for i, s in enumerate(mine) if s["kind"] == "customer")
        hover = t["text"][customer]
        assert mine[customer]["order_id"] in hover
        assert mine[customer]["arrive_time"].strftime("%H:%M:%S") in hover
        assert f"{mine[customer]['weight_kg']:.2f} kg" in hover and "delay" in hover
    depots = next(t for t in data if t.get("name") == "depots")
    assert len(depots["x"]) == 16  # every depot of the file, not only those flown from
    assert sum(t.get("name") == "service areas" for t in data) == 16
    steps = layout["sliders"][0]["steps"]
    assert [s["label"].split()[0] for s in steps] == ["all", "0", "1", "2", "3"]
    for s, w in zip(steps[1:], range(4), strict=True):
        shown = [t["uid"] for t in lines if _shown(t, s)]
        assert shown == [t["uid"] for t in lines if t["uid"].startswith(f"route-w{w}-")]
    bars, _ = figure(html, "timeline")
    assert sum(len(b["x"]) for b in bars if b["name"].endswith("flies")) == len(flown)
    day = json.loads((day_run / "metrics.json").read_text())["days"][0]
    assert f'<td class="num">{day["avg_delay_h"]:.3f}</td>' in html
    assert "not delivered by the end of the day" in html
    assert f'<td class="num">{day["undelivered"]}</td>' in html
    body = html.split("</head>")[1].replace("\\u002f", "/")
    urls = re.findall(r"https?://[^\"'\s]+", body)
    assert urls and all(u.startswith(TILE_HOST) for u in urls)  # nothing fetched but tiles


def test_every_window_of_the_slider_keeps_each_drone_in_the_legend(day_run: Path) -> None:
    """The legend names every drone that flies, whichever window the slider shows (a
    drone whose first route is in another window kept its entry only under "all")."""
    html = (day_run / "report.html").read_text(encoding="utf-8")
    data, layout = figure(html, "map")
    flown = _flown(pq.read_table(day_run / "routes.parquet").to_pylist())
    drones = sorted({r["drone"] for r in flown})
    assert len({r["window"] for r in flown if r["drone"] == drones[-1]}) > 1
    steps = layout["sliders"][0]["steps"]
    for step in steps:
        shown = [
            t["name"]
            for t in data
            if _shown(t, step) and t.get("showlegend", True) and t["name"].startswith("drone ")
        ]
        assert [int(n.split()[1]) for n in shown] == drones, step["label"]
    # Each entry stands for its drone's routes: clicking it hides them all.
    groups = {t["legendgroup"] for t in data if t.get("uid", "").startswith("route-")}
    assert groups == {f"drone {d}" for d in drones}


def test_the_map_slider_grows_with_its_windows_not_windows_times_traces(
    day_run: Path,
) -> None:
    """Each step of the map's slider names its window and no more; the page's script
    shows that window's routes. Each step held a flag for every trace of the map (a day
    of 96 windows and 3,000 routes: 288,000 flags)."""
    from marops_cli.report.daymap import WINDOW_SLIDER_SCRIPT

    html = (day_run / "report.html").read_text(encoding="utf-8")
    _, layout = figure(html, "map")
    steps = layout["sliders"][0]["steps"]
    assert [s["value"] for s in steps] == ["all", "0", "1", "2", "3"]
    assert all(s["method"] == "skip" and not s.get("args") for s in steps)
    assert "plotly_sliderchange" in html
    script = WINDOW_SLIDER_SCRIPT.strip().replace("{plot_id}", "map")
    assert script in html.replace("\\u002f", "/")


def test_the_tile_credit_waits_for_a_tile(day_run: Path) -> None:
    """The map's tile credit is hidden until a tile has loaded (the page's script shows
    it then): offline, a map without tiles credits none."""
    html = (day_run / "report.html").read_text(encoding="utf-8")
    _, layout = figure(html, "map")
    (credit,) = layout["annotations"]
    assert credit["name"] == "tile-credit" and credit["visible"] is False
    assert "Tiles ©" in credit["text"] and "tile.onload" in html


def test_the_page_is_self_contained_and_journaled(day_run: Path) -> None:
    html = (day_run / "report.html").read_text(encoding="utf-8")
    head = html.split("</head>")[0]
    assert "<script src" not in html and "<link " not in head
    # The browser lets the page load nothing but its own inline code and the tiles.
    policy = re.search(r'<meta http-equiv="Content-Security-Policy" content="([^"]+)">', head)
    assert policy is not None and head.index(policy.group(0)) < head.index("<script")
    rules = dict(r.split(" ", 1) for r in policy.group(1).split("; "))
    assert rules["default-src"] == "'none'"
    assert rules["img-src"] == f"data: blob: {TILE_HOST.rstrip('/')}"
    assert len(head) > 1_000_000  # plotly.js inlined
    journal = json.loads((day_run / ".marops-files.json").read_text())
    assert "report.html" in journal["files"]
    assert all(img["source"].startswith(TILE_HOST) for img in figure(html, "map")[1]["images"])


def test_without_tiles_the_page_fetches_nothing(
    day_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fails_cleanly
) -> None:
    """MAROPS_TILES=off: no tile on the map and none allowed, so the study area's
    location never leaves the machine; a value neither on nor off is one line."""
    copy = tmp_path / "copy"
    shutil.copytree(day_run, copy)
    (copy / "report.html").unlink()
    monkeypatch.setenv("MAROPS_TILES", "off")
    invoke("report", copy, "--quiet")
    html = (copy / "report.html").read_text(encoding="utf-8")
    head, body = html.split("</head>")
    assert "img-src data: blob:; base-uri" in head
    assert not re.findall(r"https?://[^\"'\s]+", body.replace("\\u002f", "/"))
    assert "images" not in figure(html, "map")[1]
    assert "no tiles fetched" in body
    monkeypatch.setenv("MAROPS_TILES", "maybe")
    (copy / "report.html").unlink()
    line = fails_cleanly(["report", str(copy)], copy)
    assert line == "marops: error: MAROPS_TILES expects on or off, got 'maybe'"


def test_marops_report_builds_the_same_page_from_the_folder(
    day_run: Path, depots_json: Path, tmp_path: Path
) -> None:
    copy = tmp_path / "copy"
    shutil.copytree(day_run, copy)
    (copy / "report.html").unlink()
    invoke("report", copy, "--depots", depots_json, "--quiet")
    assert (copy / "report.html").read_bytes() == (day_run / "report.html").read_bytes()
    # Without the depots file: the depots the routes use, no service areas.
    invoke("report", copy, "--quiet")
    data, _ = figure((copy / "report.html").read_text(encoding="utf-8"), "map")
    assert not any(t.get("name") == "service areas" for t in data)
    assert sum(t.get("uid", "").startswith("route-") for t in data) == len(
        _flown(pq.read_table(copy / "routes.parquet").to_pylist())
    )


def test_depots_of_another_square_are_named(
    day_run: Path, depots_json: Path, tmp_path: Path
) -> None:
    doc = json.loads(depots_json.read_text())
    doc["frame"]["center_lng"] += 1.0  # the same depots, a square one degree east
    for d in doc["depots"]:
        d["lng"] += 1.0
    said = _refused_depots(day_run, doc, tmp_path)
    assert said.startswith(f"marops: error: {tmp_path / 'other.json'}, key 'frame': the depots ")


def _refused_depots(day_run: Path, doc: dict, tmp_path: Path) -> str:
    """``marops report`` of a copy of ``day_run`` with the depots file ``doc``: refused
    in one line (returned), exit 2, nothing written."""
    other = tmp_path / "other.json"
    other.write_text(json.dumps(doc))
    copy = tmp_path / "copy"
    shutil.copytree(day_run, copy)
    before = (copy / "report.html").read_bytes()
    res = runner.invoke(app, ["report", str(copy), "--depots", str(other), "--force"])
    assert res.exit_code == 2 and len(res.stderr.splitlines()) == 1, res.stderr
    assert (copy / "report.html").read_bytes() == before  # nothing written
    return res.stderr


def _one_depot(doc: dict) -> None:
    doc["depots"], doc["candidates"] = doc["depots"][:1], {"0": [0]}


def _moved_east(doc: dict) -> None:
    for d in doc["depots"]:
        d["x_m"] += 500.0
        del d["lng"], d["lat"]  # placed by the metres alone


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        (_one_depot, "has 1 depots and the run's routes fly from depot "),
        (_moved_east, " elsewhere than the run's routes do"),
    ],
)
def test_depots_of_another_run_of_the_same_square_are_named(
    day_run: Path, depots_json: Path, tmp_path: Path, edit, says: str
) -> None:
    """A depots file of the run's square but not the run's (cut to one depot, or every
    depot 500 m east): the map drew the routes from depots it did not have, or where
    they were not; now one line naming the file, and nothing written."""
    doc = json.loads(depots_json.read_text())
    edit(doc)
    said = _refused_depots(day_run, doc, tmp_path)
    assert said.startswith(f"marops: error: {tmp_path / 'other.json'}, key 'depot': the depots ")
    assert says in said and "give the run's depots file" in said


def test_marops_report_refuses_what_it_cannot_read_or_replace(
    day_run: Path, tmp_path: Path
) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    res = runner.invoke(app, ["report", str(empty)])
    assert res.exit_code == 2 and "holds no marops outputs" in res.output
    (empty / "metrics.json").write_text('{"a": 1}')  # another tool's: it said "wrote " (exit 0)
    res = runner.invoke(app, ["report", str(empty)])
    assert res.exit_code == 2 and "holds no marops outputs" in res.output
    assert sorted(p.name for p in empty.iterdir()) == ["metrics.json"]
    copy = tmp_path / "copy"
    shutil.copytree(day_run, copy)
    (copy / "report.html").write_text("my notes")  # not marops's any more
    res = runner.invoke(app, ["report", str(copy)])
    assert res.exit_code == 2 and "not written by marops" in res.output
    assert (copy / "report.html").read_text() == "my notes"
    invoke("report", copy, "--force", "--quiet")
    assert (copy / "report.html").read_text().startswith("<!DOCTYPE html>")


@pytest.mark.parametrize(
    ("name", "damage", "says"),
    [
        ("routes.parquet", lambda p: p.write_bytes(p.read_bytes()[:3000]), "cannot be read"),
        ("metrics.json", lambda p: p.write_text("[" * 100_000 + "]" * 100_000), "nested"),
    ],
    ids=["truncated-parquet", "deep-json"],
)
def test_marops_report_on_a_damaged_output_is_one_line(
    day_run: Path, tmp_path: Path, name: str, damage, says: str
) -> None:
    copy = tmp_path / "copy"
    shutil.copytree(day_run, copy)
    damage(copy / name)
    page = (copy / "report.html").read_bytes()
    res = runner.invoke(app, ["report", str(copy), "--force"])
    lines = res.output.strip().splitlines()
    assert res.exit_code == 2 and len(lines) == 1, res.output
    assert name in lines[0] and says in lines[0]
    assert (copy / "report.html").read_bytes() == page


def test_marops_report_names_a_missing_stops_file(day_run: Path, tmp_path: Path) -> None:
    """Routes without their stops: the stops file is named as missing (the reason was
    the bare path)."""
    copy = tmp_path / "copy"
    shutil.copytree(day_run, copy)
    (copy / "stops.parquet").unlink()
    res = runner.invoke(app, ["report", str(copy), "--force"])
    assert res.exit_code == 2, res.output
    line = f"marops: error: {copy / 'stops.parquet'}: not found: the report reads it with"
    assert res.stderr.startswith(line)


@pytest.mark.parametrize("name", ["metrics.json", "stops.parquet"])
def test_marops_report_refuses_files_of_two_runs(day_run: Path, tmp_path: Path, name: str) -> None:
    """A folder's metrics or stops from another run (another seed, another method) beside
    its routes: one line naming the file and what differs, not a page mixing both."""
    copy = tmp_path / "copy"
    shutil.copytree(day_run, copy)
    if name == "metrics.json":
        doc = json.loads((copy / name).read_text(encoding="utf-8"))
        (copy / name).write_text(json.dumps({**doc, "meta": {**doc["meta"], "seed": 7}}))
        key = "key 'seed'"
    else:
        rewrite_parquet(copy / name, "order_id", lambda v: v, method="stay")
        key = "column 'method'"
    page = (copy / "report.html").read_bytes()
    res = runner.invoke(app, ["report", str(copy), "--force"])
    lines = res.output.strip().splitlines()
    assert res.exit_code == 2 and len(lines) == 1, res.output
    assert f"{copy / name}, {key}: is not of the run that wrote the routes" in lines[0]
    assert (copy / "report.html").read_bytes() == page


@pytest.mark.parametrize(
    "edit",
    [
        "times-as-numbers",
        "drone-as-text",
        "column-dropped",
        "text-metric",
        "nan-metric",
        "negative-count",
    ],
)
def test_marops_report_on_an_edited_column_is_one_line(
    day_run: Path, tmp_path: Path, edit: str
) -> None:
    """Outputs that read but hold what no run writes (times replaced by numbers, a column
    of another type or gone, a metric turned to text) are one line naming the file and
    the column or key, not a traceback; the page is left as it was."""
    import pyarrow as pa

    copy = tmp_path / "copy"
    shutil.copytree(day_run, copy)
    routes = pq.read_table(copy / "routes.parquet")
    if edit.endswith(("metric", "count")):  # NaN is Python's JSON, not the standard's
        key, value = {
            "text-metric": ("avg_delay_h", "lots"),
            "nan-metric": ("avg_delay_h", float("nan")),
            "negative-count": ("delivered", -5),
        }[edit]
        doc = json.loads((copy / "metrics.json").read_text())
        doc["days"][0][key] = value
        (copy / "metrics.json").write_text(json.dumps(doc))
        file, column = "metrics.json", f"key 'days[0].{key}'"
    else:
        name = {"times-as-numbers": "window_start"}.get(edit, "drone")
        i = routes.schema.get_field_index(name)
        if edit == "column-dropped":
            edited = routes.remove_column(i)
        else:
            value = 0.5 if name == "window_start" else "0"
            edited = routes.set_column(i, name, pa.array([value] * routes.num_rows))
        meta = routes.schema.metadata
        pq.write_table(edited.replace_schema_metadata(meta), copy / "routes.parquet")
        file, column = "routes.parquet", f"column '{name}'"
    page = (copy / "report.html").read_bytes()
    res = runner.invoke(app, ["report", str(copy), "--force"])
    lines = res.output.strip().splitlines()
    assert res.exit_code == 2 and len(lines) == 1, res.output
    assert f"{copy / file}, {column}: " in lines[0]
    assert (copy / "report.html").read_bytes() == page


def test_without_plotly_report_is_one_line_naming_the_extra(
    example_csv: Path, day_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "plotly", None)  # import plotly fails
    out = tmp_path / "never"
    res = runner.invoke(
        app, ["replay-day", str(example_csv), "--date", "0811", "--report", "--out", str(out)]
    )
    assert res.exit_code == 2
    assert "pip install 'marops[report]'" in res.output
    assert not out.exists()  # stopped before any work
    res = runner.invoke(app, ["report", str(day_run)])
    assert res.exit_code == 2 and "marops[report]" in res.output


def test_plan_window_report(
    example_csv: Path, depots_json: Path, small_config: Path, tmp_path: Path
) -> None:
    out = tmp_path / "w2"
    invoke(
        "plan-window", example_csv, "--depots", depots_json, "--date", "0811", "--window", 2,
        "--drones", 3, "--config", small_config, "--format", "json", "--report",
        "--out", out, "--quiet",
    )  # fmt: skip
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "window 2" in html.split("</h1>")[0]
    data, layout = figure(html, "map")  # read from the JSON route files
    flown = _flown(json.loads((out / "routes.json").read_text())["routes"])
    assert sum(t.get("uid", "").startswith("route-") for t in data) == len(flown)
    assert "sliders" not in layout  # one window: nothing to slide
    assert "solver status" in html
    long_numbers = re.findall(r'<td class="num">[-+]?\d*\.\d{7,}</td>', html)
    assert long_numbers == []  # six significant digits, the solver's objective's too
    # Energies as plan-window prints them: MJ (kJ for the routes'), not raw joules.
    score = json.loads((out / "routes.json").read_text())["meta"]["objective"]
    j_mj, energy_kj = score["J"] / 1e6, score["energy_j"] / 1e3
    assert f'<td>window objective J</td><td class="num">{j_mj:,.3f} MJ</td>' in html
    assert f'<td>energy of the routes</td><td class="num">{energy_kj:,.1f} kJ</td>' in html
    assert "<td>J</td>" not in html and "<td>energy_j</td>" not in html and "e+07" not in html
    # A window's flights last minutes: ticks half a minute apart show their seconds (at
    # %H:%M two of them read the same), ticks a minute or more apart do not.
    _, timeline = figure(html, "timeline")
    stops = timeline["xaxis"]["tickformatstops"]
    assert {"dtickrange": [None, 60_000], "value": "%H:%M:%S"} in stops
    assert {"dtickrange": [60_000, None], "value": "%H:%M"} in stops
    assert "tickformat" not in timeline["xaxis"]


def test_several_days_link_each_day_report(
    example_csv: Path, depots_json: Path, small_config: Path, tmp_path: Path
) -> None:
    out = tmp_path / "days"
    res = invoke(
        "replay-day", example_csv, "--dates", "0811..0812", "--depots", depots_json,
        "--drones", 2, "--config", small_config, "--workers", 1, "--report", "--out", out,
    )  # fmt: skip
    top = (out / "report.html").read_text(encoding="utf-8")
    for day in ("2022-08-11", "2022-08-12"):
        assert f'href="{day}/report.html"' in top
        page = (out / day / "report.html").read_text(encoding="utf-8")
        assert '↑ <a href="../report.html">the run&#x27;s page (days)</a>' in page
    figure(top, "days")
    # A page at a time: a city's month makes hundreds, each said as it is written.
    pages = [
        f"report 1/3: {out / '2022-08-11' / 'report.html'}",
        f"report 2/3: {out / '2022-08-12' / 'report.html'}",
        f"report 3/3: {out / 'report.html'}",
    ]
    assert [line for line in res.output.splitlines() if line.startswith("report ")] == pages
    res = invoke("report", out)
    assert res.output.splitlines()[:3] == pages


def test_marops_report_on_a_run_stopped_before_its_summary_reports_its_days(
    days_run: Path, tmp_path: Path
) -> None:
    """A ``--dates`` run stopped half-way keeps the days it finished, and no metrics.json
    over them: ``marops report`` makes the days' pages, saying in one line that the run
    did not finish, where it said the folder held no outputs."""
    out = tmp_path / "days"
    shutil.copytree(days_run, out)
    for name in ("metrics.json", "report.html", "2022-08-11/report.html"):
        (out / name).unlink()
    shutil.rmtree(out / "2022-08-12")
    res = invoke("report", out)
    said = [line for line in res.output.splitlines() if line.startswith("warning: ")]
    assert said == [
        f"warning: {out} holds no metrics.json over its days: its run did not finish (which "
        "days it was to replay is not recorded); reporting the 1 day there (2022-08-11); "
        "the same replay-day again finishes it, keeping these"
    ]
    assert (out / "2022-08-11" / "report.html").is_file()
    assert not (out / "report.html").exists()  # no page over days it does not have
    # A folder of no run's days is still said to hold no outputs (a file named as a day
    # is no day's folder).
    (tmp_path / "other" / "2022-08-11").mkdir(parents=True)
    (tmp_path / "other" / "2022-08-12").write_text("")
    res = runner.invoke(app, ["report", str(tmp_path / "other")])
    assert res.exit_code == 2 and "holds no marops outputs" in res.output


def _policy(page: str) -> dict[str, str]:
    head = page.split("</head>")[0]
    found = re.search(r'<meta http-equiv="Content-Security-Policy" content="([^"]+)">', head)
    assert found is not None
    return dict(r.split(" ", 1) for r in found.group(1).split("; "))


def test_the_pages_of_several_days_share_one_plotly_js(
    days_run: Path, depots_json: Path, tmp_path: Path
) -> None:
    """One plotly.js under the run's folder, journaled as marops's; each page loads it
    by its relative path (its policy allows that and no host) instead of inlining it."""
    from plotly.offline import get_plotlyjs, get_plotlyjs_version

    name = f"plotly-{get_plotlyjs_version()}.min.js"
    assert [p.relative_to(days_run).as_posix() for p in days_run.rglob("*.js")] == [name]
    assert (days_run / name).read_bytes() == get_plotlyjs().encode("utf-8")
    journal = json.loads((days_run / ".marops-files.json").read_text())
    assert name in journal["files"] and "report.html" in journal["files"]
    pages = {
        days_run / "report.html": name,
        days_run / "2022-08-11" / "report.html": f"../{name}",
        days_run / "2022-08-12" / "report.html": f"../{name}",
    }
    for path, src in pages.items():
        page = path.read_text(encoding="utf-8")
        assert page.count("<script src") == 1
        assert f'<script src="{src}"></script>' in page.split("</head>")[0]
        assert _policy(page)["script-src"] == "'self' 'unsafe-inline'"
        assert len(page) < 1_000_000  # plotly.js is not inlined
    # The same folder gives the same bytes (its name is on the pages); a day's page made
    # alone inlines plotly.js and opens on its own.
    copy = tmp_path / days_run.name
    shutil.copytree(days_run, copy)
    invoke("report", copy, "--depots", depots_json, "--quiet")
    for path in [*pages, days_run / name]:
        assert (copy / path.relative_to(days_run)).read_bytes() == path.read_bytes()
    invoke("report", copy / "2022-08-11", "--depots", depots_json, "--quiet")
    alone = (copy / "2022-08-11" / "report.html").read_text(encoding="utf-8")
    assert "<script src" not in alone and _policy(alone)["script-src"] == "'unsafe-inline'"
    shared = (days_run / "2022-08-11" / "report.html").read_text(encoding="utf-8")
    assert len(alone) - len(shared) > 4_000_000
    assert figure(alone, "map") == figure(shared, "map")  # the same figures


def test_a_plotly_js_marops_did_not_write_is_never_replaced(
    days_run: Path, example_csv: Path, depots_json: Path, small_config: Path, tmp_path: Path,
    fails_cleanly,
) -> None:  # fmt: skip
    """A file of one's own by the shared plotly.js's name (or marops's, edited since)
    stops the report before any work, as any output marops did not write."""
    from marops_cli.report.page import script_name

    name = script_name()
    out = tmp_path / "days"
    out.mkdir()
    (out / name).write_text("my script")
    args = [
        "replay-day", str(example_csv), "--dates", "0811..0812", "--depots", str(depots_json),
        "--drones", "2", "--config", str(small_config), "--workers", "1", "--report",
        "--out", str(out),
    ]  # fmt: skip
    fails_cleanly(args, out, str(out / name), "not written by marops")
    assert (out / name).read_text() == "my script"
    copy = tmp_path / "copy"
    shutil.copytree(days_run, copy)
    with (copy / name).open("a") as fh:
        fh.write("\n// edited")
    edited = (copy / name).read_bytes()
    pages = {p: p.read_bytes() for p in copy.rglob("report.html")}
    line = fails_cleanly(["report", str(copy)], copy, str(copy / name))
    assert "not written by marops" in line
    assert (copy / name).read_bytes() == edited
    assert {p: p.read_bytes() for p in copy.rglob("report.html")} == pages
    # The library's own check, where no command checked the outputs before.
    from marops_cli.errors import InputError
    from marops_cli.report import write_reports

    with pytest.raises(InputError, match="not written by marops"):
        write_reports(copy)
    assert (copy / name).read_bytes() == edited
    assert {p: p.read_bytes() for p in copy.rglob("report.html")} == pages
    assert not [p for p in copy.rglob("*.tmp")]
    # --force replaces it, as any output marops did not write.
    invoke("report", copy, "--force", "--quiet")
    assert (copy / name).read_bytes() == (days_run / name).read_bytes()


def test_a_folder_that_cannot_be_reported_on_leaves_no_shared_plotly_js(
    days_run: Path, tmp_path: Path
) -> None:
    """The pages of several days and the plotly.js they share are put in place together
    or not at all: a damaged day leaves the folder as it was."""
    from marops_cli.report.page import script_name

    copy = tmp_path / "copy"
    shutil.copytree(days_run, copy)
    for p in [*copy.rglob("report.html"), copy / script_name()]:
        p.unlink()
    routes = copy / "2022-08-12" / "routes.parquet"
    routes.write_bytes(routes.read_bytes()[:3000])
    before = sorted(copy.rglob("*"))
    res = runner.invoke(app, ["report", str(copy)])
    assert res.exit_code == 2 and "routes.parquet" in res.output, res.output
    assert sorted(copy.rglob("*")) == before


def test_the_closing_line_of_many_pages_names_the_first_and_the_last() -> None:
    from marops_cli.cli.report_cmd import wrote_pages

    few = [Path(f"out/2022-08-0{d}/report.html") for d in range(1, 4)]
    assert wrote_pages(few) == "wrote " + ", ".join(map(str, few))
    many = [Path(f"out/2022-08-{d:02}/report.html") for d in range(1, 31)] + [
        Path("out/report.html")
    ]
    assert wrote_pages(many) == "wrote 31 files: out/2022-08-01/report.html, …, out/report.html"


def test_hub_folders_are_walked_in_the_order_of_their_numbers(tmp_path: Path) -> None:
    """A city run's hub-2 comes before hub-10 (not after it, as in plain text order)."""
    from marops_cli.report import report_folders

    out = tmp_path / "city"
    for hub in (10, 2, 1):
        (out / f"hub-{hub}").mkdir(parents=True)
        (out / f"hub-{hub}" / "metrics.json").write_text('{"total": {"delivered": 1}}')
    (out / "metrics.json").write_text('{"total": {"delivered": 3}}')
    found = [p.relative_to(out).as_posix() for p in report_folders(out)]
    assert found == ["hub-1", "hub-2", "hub-10", "."]


def test_a_city_page_links_its_hubs_and_each_page_links_the_one_above(tmp_path: Path) -> None:
    """From the city's page to a hub's, and from a hub's or a day's back up: an analyst
    moves through a city's month by links. A city of one hub (hub 0) has hub-days too."""
    out = tmp_path / "city"
    day = {"day": "2022-08-11", "method": "stay", "hub": 0}
    (out / "hub-0" / "2022-08-11").mkdir(parents=True)
    (out / "hub-0" / "2022-08-11" / "metrics.json").write_text(json.dumps(day))
    (out / "hub-0" / "metrics.json").write_text(json.dumps({"days": [day], "total": {"days": 1}}))
    (out / "metrics.json").write_text(
        json.dumps({"days": [day], "total": {"days": 1}, "city": {"hubs": 1}})
    )
    invoke("report", out, "--quiet")
    city = (out / "report.html").read_text(encoding="utf-8")
    assert city.count('href="hub-0/report.html"') == 1  # the hubs' table
    assert city.count('href="hub-0/2022-08-11/report.html"') == 1  # the days' table
    assert "../report.html" not in city  # the top page has nothing above it
    assert "<title>marops: 1 hub-day — city</title>" in city
    hub = (out / "hub-0" / "report.html").read_text(encoding="utf-8")
    assert '↑ <a href="../report.html">the run&#x27;s page (city)</a>' in hub


def test_a_day_folder_named_like_a_script_url_links_as_a_path(tmp_path: Path) -> None:
    """A several-day folder from elsewhere whose day is named ``javascript:…``: its link
    is that folder, percent-encoded, not a script run by a click."""
    name = "javascript:document.title='x';0"
    out = tmp_path / "days"
    (out / name).mkdir(parents=True)
    (out / name / "metrics.json").write_text('{"total": {"delivered": 1}}')
    days = {"days": [{"day": name, "method": "stay"}], "total": {"delivered": 1}}
    (out / "metrics.json").write_text(json.dumps(days))
    invoke("report", out, "--quiet")
    top = (out / "report.html").read_text(encoding="utf-8")
    assert 'href="javascript%3Adocument.title%3D%27x%27%3B0/report.html"' in top
    assert 'href="javascript:' not in top.split("</head>")[1]


def test_evaluate_report_tables_paired_and_sweep(evaluation_run: Path, tmp_path: Path) -> None:
    out = tmp_path / "ev"
    shutil.copytree(evaluation_run, out)
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "Setting 0: α = 0.2" in html and "Setting 1: α = 0.8" in html
    assert "<th>stay</th><th>greedy</th>" in html
    paired, _ = figure(html, "paired")
    n_metrics = len({r["metric"] for r in _csv_rows(out / "paired.csv")})
    assert len(paired) == n_metrics
    for trace in paired:  # greedy against stay in both settings, with its interval
        assert len(trace["x"]) == 2 and "array" in trace["error_x"]
    sweep, layout = figure(html, "sweep-alpha")
    assert {t["name"] for t in sweep} == {"stay", "greedy"}
    assert all(t["x"] == [0.2, 0.8] for t in sweep)
    figure(html, "days")
    journal = json.loads((out / ".marops-files.json").read_text())
    assert "report.html" in journal["files"]
    # A damaged results table: one line naming it, the page left as it was.
    (out / "results.parquet").write_bytes((out / "results.parquet").read_bytes()[:500])
    res = runner.invoke(app, ["report", str(out), "--force"])
    lines = res.output.strip().splitlines()
    assert res.exit_code == 2 and len(lines) == 1 and "results.parquet" in lines[0], res.output
    assert (out / "report.html").read_text(encoding="utf-8") == html


def test_every_paired_interval_is_labelled_under_its_metrics_name(
    evaluation_run: Path, tmp_path: Path
) -> None:
    """A sweep's paired comparison of 21 settings: each panel a tick label per interval
    (plotly would thin them to about one in three) and a height per row; panel titles
    the metric's name as the summary tables give it, and which way is better."""
    import csv

    copy = tmp_path / "ev"
    shutil.copytree(evaluation_run, copy)
    rows = _csv_rows(copy / "paired.csv")
    many = [dict(r, setting=str(k)) for r in rows if r["setting"] == "0" for k in range(21)]
    with (copy / "paired.csv").open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(many)
    invoke("report", copy, "--quiet", "--force")  # the table edited is no more marops's
    data, layout = figure((copy / "report.html").read_text(encoding="utf-8"), "paired")
    metrics = list(dict.fromkeys(r["metric"] for r in many))
    assert len(data) == len(metrics) and all(len(t["y"]) == 21 for t in data)
    for trace in data:
        axis = layout["yaxis" + trace.get("yaxis", "y")[1:]]
        assert axis["tickmode"] == "array" and axis["tickvals"] == trace["y"]
        assert len(set(trace["y"])) == 21
    assert layout["height"] >= 20 * 21 * len(metrics)
    titles = [a["text"] for a in layout["annotations"] if "is better" in a["text"]]
    assert len(titles) == len(metrics)
    assert "Day objective J (MJ), method − stay: lower is better" in titles
    assert "Delivered share, method − stay: higher is better" in titles
    assert not [t for t in titles if "_" in t]  # no column names


def test_a_sweep_draws_each_method_in_its_legend_colour_in_every_panel(
    evaluation_run: Path,
) -> None:
    """One legend entry per method stands for its line in every panel: the same colour
    there (plotly would give each panel's line the next colour)."""
    sweep, _ = figure((evaluation_run / "report.html").read_text(encoding="utf-8"), "sweep-alpha")
    colours: dict[str, set[str]] = {}
    for t in sweep:
        colours.setdefault(t["name"], set()).add(t.get("line", {}).get("color"))
    assert len({t.get("xaxis") for t in sweep}) > 1  # several panels
    assert all(len(c) == 1 and None not in c for c in colours.values()), colours
    assert len({c for cs in colours.values() for c in cs}) == len(colours)


def test_the_days_of_several_hubs_and_repeats_say_which_on_hover(
    evaluation_run: Path, tmp_path: Path
) -> None:
    """A city's evaluation puts a point per hub (and per repeat) on each day: its hover
    names them."""
    copy = tmp_path / "ev"
    shutil.copytree(evaluation_run, copy)
    n = iter(range(10**6))
    rewrite_parquet(copy / "results.parquet", "hub", lambda v: next(n) % 3)
    rewrite_parquet(copy / "results.parquet", "repeat", lambda v: 1)
    invoke("report", copy, "--quiet")
    days, _ = figure((copy / "report.html").read_text(encoding="utf-8"), "days")
    texts = [t for trace in days for t in trace["text"]]
    assert {t.split(",")[0] for t in texts} == {"hub 0", "hub 1", "hub 2"}
    assert all(t.split(", ")[1] == "repeat 1" for t in texts)
    assert all(t.split(", ")[2].startswith("delivered share ") for t in texts)
    # One study area, one run a day: the hover as it was.
    days, _ = figure((evaluation_run / "report.html").read_text(encoding="utf-8"), "days")
    assert all(t.startswith("delivered share ") for trace in days for t in trace["text"])


def test_the_paired_table_says_each_verdict_and_how_few_days_back_it(
    evaluation_run: Path, tmp_path: Path
) -> None:
    """As evaluate says on the terminal: a verdict per row, and a warning where fewer
    than ten days back the intervals."""
    html = (evaluation_run / "report.html").read_text(encoding="utf-8")
    assert "<th>days better</th><th>verdict</th>" in html
    assert "<td>too few days (n=1)</td></tr>" in html  # one day: no verdict
    assert "<td>better</td>" not in html and "<td>worse</td>" not in html
    assert "Fewer than 10 days back these differences" in html
    assert "Only 1 day backs the comparison (fewer than 10)" in html  # the tables' too
    # Ten days or more: no warning; a verdict from the interval.
    copy = tmp_path / "ev"
    shutil.copytree(evaluation_run, copy)
    rows = _csv_rows(copy / "paired.csv")
    for r in rows:
        r.update(days="12", calendar_days="12", few_days="false", ci_low="-2.0", ci_high="-1.0")
    with (copy / "paired.csv").open("w", newline="") as fh:
        import csv

        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    invoke("report", copy, "--quiet", "--force")  # the table edited is no more marops's
    html = (copy / "report.html").read_text(encoding="utf-8")
    assert "Fewer than 10 days" not in html
    assert "<td>better</td>" in html and "<td>worse</td>" in html


def _csv_rows(path: Path) -> list[dict]:
    import csv

    with path.open() as fh:
        return list(csv.DictReader(fh))


def test_a_foreign_report_stops_the_run_before_the_work(example_csv: Path, tmp_path: Path) -> None:
    out = tmp_path / "day"
    out.mkdir()
    (out / "report.html").write_text("someone's page")
    res = runner.invoke(
        app, ["replay-day", str(example_csv), "--date", "0811", "--report", "--out", str(out)]
    )
    assert res.exit_code == 2 and "report.html" in res.output
    assert sorted(p.name for p in out.iterdir()) == ["report.html"]  # nothing computed


def test_the_api_writes_the_same_page(day_run: Path, depots_json: Path, tmp_path: Path) -> None:
    from marops_cli import api

    copy = tmp_path / "copy"
    shutil.copytree(day_run, copy)
    (copy / "report.html").unlink()
    assert api.report(copy, depots=depots_json) == [copy / "report.html"]
    assert (copy / "report.html").read_bytes() == (day_run / "report.html").read_bytes()


def test_a_city_run_reports_each_hub_and_the_city(
    example_csv: Path, small_config: Path, tmp_path: Path
) -> None:
    hubs = tmp_path / "hubs.json"
    invoke("segment", example_csv, "--hubs", 2, "--dates", "0801..0810", "--out", hubs, "--quiet")
    out = tmp_path / "city"
    invoke(
        "replay-day", example_csv, "--hubs", hubs, "--date", "0811", "--drones", 2,
        "--config", small_config, "--workers", 1, "--report", "--out", out, "--quiet",
    )  # fmt: skip
    city = (out / "report.html").read_text(encoding="utf-8")
    assert "The city&#x27;s coverage" in city or "The city's coverage" in city
    # One plotly.js for the city's pages, in its folder, written once.
    from marops_cli.report.page import script_name

    name = script_name()
    assert list(out.rglob("*.js")) == [out / name]
    for hub in (0, 1):
        assert f'href="hub-{hub}/report.html"' in city
        page = (out / f"hub-{hub}" / "report.html").read_text(encoding="utf-8")
        assert f'<script src="../{name}"></script>' in page
        data, _ = figure(page, "map")
        assert sum(t.get("name") == "service areas" for t in data) > 0  # the hub's own depots
        assert '↑ <a href="../report.html">' in page  # up to the city's page
    assert f'<script src="{name}"></script>' in city
    # The page opens on the city's map: each hub's square where hubs.json places it.
    assert city.index('id="city-map"') < city.index("<h2>Days</h2>")
    data, _ = figure(city, "city-map")
    squares = [t for t in data if t.get("uid", "").startswith("hub-")]
    for h, t in zip(json.loads(hubs.read_text())["hubs"], squares, strict=True):
        assert t["uid"] == f"hub-{h['id']}"
        assert min(t["x"]) < h["center_lng"] < max(t["x"])
        assert min(t["y"]) < h["center_lat"] < max(t["y"])


def test_marops_report_on_an_edited_json_route_file_names_the_key(
    example_csv: Path, small_config: Path, depots_json: Path, tmp_path: Path
) -> None:
    """A --format json day whose routes were edited (a drone's number turned to text, a
    key gone): one line naming the file and the row's key, as for Parquet."""
    from .conftest import invoke

    out = tmp_path / "json"
    invoke(
        "replay-day", example_csv, "--date", "0811", "--depots", depots_json, "--drones", 2,
        "--config", small_config, "--format", "json", "--out", out, "--quiet",
    )  # fmt: skip
    doc = json.loads((out / "routes.json").read_text())
    doc["routes"][1]["drone"] = "x"
    (out / "routes.json").write_text(json.dumps(doc))
    res = runner.invoke(app, ["report", str(out)])
    assert res.exit_code == 2, res.output
    assert f"{out / 'routes.json'}, key 'routes[1].drone': expected a whole number" in res.output
    del doc["routes"][1]["drone"]
    (out / "routes.json").write_text(json.dumps(doc))
    res = runner.invoke(app, ["report", str(out)])
    assert res.exit_code == 2 and "key 'routes[1].drone': has no 'drone'" in res.output
    assert not (out / "report.html").exists()


def _refused(folder: Path, page: bytes) -> str:
    """``marops report --force`` on ``folder``, refused: its one line; the page as it was
    (``page``: its bytes), nothing else written."""
    res = runner.invoke(app, ["report", str(folder), "--force"])
    lines = res.output.strip().splitlines()
    assert res.exit_code == 2 and len(lines) == 1, res.output
    assert (folder / "report.html").read_bytes() == page
    return lines[0]


def _write_csv(path: Path, rows: list[dict]) -> None:
    import csv

    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


_FINITE = "expected a finite number, got"


@pytest.mark.parametrize(
    ("name", "column", "value", "at", "says"),
    [
        ("summary.csv", "mean_energy_kj_mean", "nan", "all", f"{_FINITE} an empty cell or nan"),
        ("summary.csv", "avg_delay_h_mean", "inf", 1, f"{_FINITE} inf"),
        ("summary.csv", "alpha", "x", 1, f"{_FINITE} 'x'"),
        ("summary.csv", "method", None, None, "has no column 'method'"),
        ("results.parquet", "day", None, None, "has no column 'day'"),
        ("paired.csv", "mean_diff", "lots", 1, "expected a number, got 'lots'"),
        ("frontier.csv", "dominated", "perhaps", 2, "expected true or false, got 'perhaps'"),
    ],
    ids=["nan-mean", "inf-mean", "text-alpha", "no-method", "no-day", "text-diff", "text-flag"],
)
def test_marops_report_on_an_edited_evaluation_table_names_its_row_and_column(
    evaluation_run: Path, tmp_path: Path, name: str, column: str, value: str | None, at, says: str
) -> None:
    """An evaluation's table edited (a mean turned to NaN, infinity or text, a column
    gone): one line naming the file, the row (the header is row 1) and the column, as
    the data's readers say it; the page left as it was. The page was an error of its
    own making that named the folder alone (``unsupported format string``)."""
    copy = tmp_path / "ev"
    shutil.copytree(evaluation_run, copy)
    path = copy / name
    if name.endswith(".parquet"):
        table = pq.read_table(path)
        edited = table.remove_column(table.schema.get_field_index(column))
        pq.write_table(edited.replace_schema_metadata(table.schema.metadata), path)
    else:
        rows = _csv_rows(path)
        for i, r in enumerate(rows):
            if value is None:
                del r[column]
            elif at in ("all", i):
                r[column] = value
        _write_csv(path, rows)
    line = _refused(copy, (copy / "report.html").read_bytes())
    row = "" if at is None else f"row {2 if at == 'all' else at + 2}, "
    assert line.startswith(f"marops: error: {path}, {row}column '{column}': "), line
    assert says in line


def test_what_no_check_catches_is_named_by_the_file_the_page_was_reading(
    evaluation_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The last resort, where a file holds what its checks let through and the page
    cannot use: one line naming the file whose part of the page failed, not the folder."""
    import marops_cli.evaluate.report as tables

    def fails(*args: object) -> None:
        raise KeyError("avg_delay_h_std")

    monkeypatch.setattr(tables, "table3", fails)
    copy = tmp_path / "ev"
    shutil.copytree(evaluation_run, copy)
    line = _refused(copy, (copy / "report.html").read_bytes())
    said = f"marops: error: {copy / 'summary.csv'}: holds what marops cannot report on, edited"
    assert line.startswith(said) and line.endswith("('avg_delay_h_std')"), line


def test_nan_that_an_evaluation_writes_is_shown_not_refused(
    evaluation_run: Path, tmp_path: Path
) -> None:
    """NaN an evaluation writes (a paired difference over no shared day, the energy per
    parcel of a point that delivers none) reads back from the CSV as an empty cell: the
    page shows it (it stopped on formatting an empty cell)."""
    copy = tmp_path / "ev"
    shutil.copytree(evaluation_run, copy)
    paired = _csv_rows(copy / "paired.csv")
    paired[0].update(mean_diff="nan", ci_low="nan", ci_high="nan")
    _write_csv(copy / "paired.csv", paired)
    front = _csv_rows(copy / "frontier.csv")
    front[0].update(energy_per_parcel_kj="nan")
    _write_csv(copy / "frontier.csv", front)
    invoke("report", copy, "--quiet", "--force")
    html = (copy / "report.html").read_text(encoding="utf-8")
    assert "<td>n/a</td><td>[n/a, n/a]</td><td>0/1</td><td>n/a</td>" in html  # paired
    assert "<td>n/a</td><td>—</td>" in html  # the frontier's kJ per parcel


def _first_customer(doc: dict) -> int:
    return next(i for i, s in enumerate(doc["stops"]) if s["kind"] == "customer")


def _first_flown(doc: dict) -> int:
    return next(i for i, r in enumerate(doc["routes"]) if r["n_parcels"] > 0)


_KINDS = "expected one of 'start', 'customer', 'end', got"
_ISO = "expected a time (ISO 8601: 2022-08-11T09:00:00+08:00), got"


@pytest.mark.parametrize(
    ("name", "key", "value", "says"),
    [
        ("stops.json", "stops[{i}].arrive_time", "garbage", f"{_ISO} 'garbage'"),
        ("routes.json", "routes[{i}].window_start", 12345, f"{_ISO} 12345"),
        ("stops.json", "stops[{i}].kind", 5, f"{_KINDS} 5"),
        ("stops.json", "stops[{i}].kind", "teleport", f"{_KINDS} 'teleport'"),
        ("stops.json", "stops[{i}].lng", float("nan"), f"{_FINITE} nan"),
        ("stops.json", "stops[{i}].weight_kg", None, f"{_FINITE} null"),
        ("routes.json", "meta.solver", [1], "expected an object, got [1]"),
        ("routes.json", "meta", "x", "expected an object, got 'x'"),
        ("routes.json", "routes[{i}].drone", 99, "drone 99 flies in window 0, but stops.json has"),
        ("metrics.json", "days", "x", "expected a list, got 'x'"),
    ],
    ids=[
        "text-time", "number-time", "number-kind", "unknown-kind", "nan-number",
        "empty-weight", "list-solver", "text-meta", "flight-without-stops", "text-days",
    ],
)  # fmt: skip
def test_marops_report_on_an_edited_json_output_names_the_key(
    json_day_run: Path, tmp_path: Path, name: str, key: str, value: object, says: str
) -> None:
    """A --format json day's files edited (a time that is none, a stop of no kind marops
    knows, NaN, metadata of another type, a flight without its stops): one line naming
    the file and the key, the page left as it was. Each was an error of the page's
    making that named the folder alone (``Invalid isoformat string``)."""
    copy = tmp_path / "day"
    shutil.copytree(json_day_run, copy)
    path = copy / name
    doc = json.loads(path.read_text(encoding="utf-8"))
    i = _first_customer(doc) if name == "stops.json" else 0
    i = _first_flown(doc) if key.startswith("routes[") else i
    *parents, last = key.format(i=i).replace("[", ".").replace("]", "").split(".")
    held = doc
    for k in parents:
        held = held[int(k) if k.isdigit() else k]
    held[last] = value
    path.write_text(json.dumps(doc), encoding="utf-8")  # NaN as Python's JSON writes it
    line = _refused(copy, (copy / "report.html").read_bytes())
    if key.endswith(".drone"):  # the flight is named, not its drone's key
        key = key.removesuffix(".drone")
    assert line.startswith(f"marops: error: {path}, key '{key.format(i=i)}': {says}"), line


def test_marops_report_refuses_a_route_json_file_past_the_route_file_cap(
    json_day_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A stops.json larger than any day's (the cap the API reads a kept day back with,
    made small here) is one line naming it, exit 2, the page as it was: the report read
    route JSON files whole, of any size."""
    import marops_cli.io.routejson

    copy = tmp_path / "day"
    shutil.copytree(json_day_run, copy)
    path = copy / "stops.json"
    monkeypatch.setattr(marops_cli.io.routejson, "MAX_ROUTE_JSON", path.stat().st_size - 1)
    line = _refused(copy, (copy / "report.html").read_bytes())
    assert line == f"marops: error: {path}: stops file is larger than 0 MiB", line


def _set_cells(path: Path, column: str, cells: dict[int, object]) -> None:
    """Parquet ``column``'s rows ``cells`` (0-based) set, its type and the file's
    metadata kept."""
    import pyarrow as pa

    table = pq.read_table(path)
    values = table.column(column).to_pylist()
    for i, v in cells.items():
        values[i] = v
    field = table.schema.field(column)
    new = pa.array(values, type=field.type)
    table = table.set_column(table.schema.get_field_index(column), field, new)
    pq.write_table(table, path)


@pytest.mark.parametrize(
    ("name", "column", "value", "says"),
    [
        ("stops.parquet", "kind", "teleport", f"{_KINDS} 'teleport'"),
        ("stops.parquet", "arrive_time", None, "expected a time, got an empty cell"),
        ("stops.parquet", "weight_kg", None, f"{_FINITE} an empty cell"),
        ("stops.parquet", "lat", float("inf"), f"{_FINITE} inf"),
        ("routes.parquet", "drone", 99, "drone 99 flies in window 0, but stops.parquet has"),
    ],
    ids=["unknown-kind", "empty-time", "empty-weight", "inf-number", "flight-without-stops"],
)
def test_marops_report_on_an_edited_route_table_names_its_row_and_column(
    day_run: Path, tmp_path: Path, name: str, column: str, value: object, says: str
) -> None:
    """A day's Parquet files edited in a cell, each column of its type (a stop of no
    kind marops knows, a time or a customer's weight emptied, a flight without its
    stops): one line naming the file, the row and the column, not an error of the
    page's making naming the folder alone."""
    copy = tmp_path / "day"
    shutil.copytree(day_run, copy)
    path = copy / name
    rows = pq.read_table(path).to_pylist()
    if name == "stops.parquet":
        i = next(k for k, s in enumerate(rows) if s["kind"] == "customer")
    else:
        i = next(k for k, r in enumerate(rows) if r["n_parcels"] > 0 and r["window"] == 0)
    _set_cells(path, column, {i: value})
    line = _refused(copy, (copy / "report.html").read_bytes())
    at = f"row {i + 2}" + (f", column '{column}'" if name == "stops.parquet" else "")
    assert line.startswith(f"marops: error: {path}, {at}: {says}"), line


@pytest.mark.parametrize("name", ["stops.parquet", "routes.parquet"])
def test_marops_report_refuses_rows_repeated_in_a_route_table(
    day_run: Path, tmp_path: Path, name: str
) -> None:
    """A day's route table whose rows were copied within it (each drone's route or stop
    twice, or a hundred times): one line naming the file and the first repeated row, not
    a map that draws every copy of a route with every copy of its stops (a file of a few
    hundred kilobytes held minutes and gigabytes)."""
    import pyarrow as pa

    copy = tmp_path / "day"
    shutil.copytree(day_run, copy)
    path = copy / name
    table = pq.read_table(path)
    pq.write_table(pa.concat_tables([table, table]), path)  # the marops metadata kept
    line = _refused(copy, (copy / "report.html").read_bytes())
    first = table.slice(0, 1).to_pylist()[0]
    said = f"window {first['window']}, drone {first['drone']}"
    said += ", seq 0" if name == "stops.parquet" else ""
    assert line.startswith(
        f"marops: error: {path}, row {table.num_rows + 2}: repeats row 2 ({said})"
    ), line


def test_marops_report_refuses_more_rows_than_any_run_writes_unread(
    day_run: Path, evaluation_run: Path, tmp_path: Path, monkeypatch
) -> None:
    """An evaluation's results of more rows than the replays one evaluation runs, or a
    day's routes of more than a day of one study area has: one line naming the file, by
    its footer, before any row is read (a 1 MB results file of 2 million repeated rows
    held 26 s and 3.3 GB; 20 MB, 30 GB)."""
    import numpy as np
    import pyarrow as pa

    import marops_cli.config
    from marops_cli.evaluate.settings import MAX_REPLAYS

    ev = tmp_path / "ev"
    shutil.copytree(evaluation_run, ev)
    path = ev / "results.parquet"
    table = pq.read_table(path)
    rows = np.arange(MAX_REPLAYS + 1) % table.num_rows
    pq.write_table(table.take(pa.array(rows)).replace_schema_metadata(table.schema.metadata), path)
    line = _refused(ev, (ev / "report.html").read_bytes())
    assert line == (
        f"marops: error: {path}: holds {MAX_REPLAYS + 1:,} rows, more than the "
        f"{MAX_REPLAYS:,} replays an evaluation runs: edited since marops wrote it"
    )
    day = tmp_path / "day"
    shutil.copytree(day_run, day)
    n = pq.read_metadata(day / "routes.parquet").num_rows
    monkeypatch.setattr(marops_cli.config, "MAX_DAY_ROUTES", n - 1)  # no 1.4 million rows
    line = _refused(day, (day / "report.html").read_bytes())
    assert line.startswith(f"marops: error: {day / 'routes.parquet'}: holds {n:,} rows"), line


def test_the_city_map_draws_what_the_files_hold_and_leaves_out_the_rest(tmp_path: Path) -> None:
    """A city folder whose files hold less than a run writes today (no per-hub rows in
    the city block, a day without its planned orders, a hub whose files name no square):
    the map draws the squares it finds with the figures it has, and says which hub it
    could not place; the figures missing are left out, not shown as 0."""
    out = tmp_path / "city"
    days = [
        {"day": "2022-08-11", "method": "stay", "hub": 0, "orders_due": 50, "requests": 30,
         "delivered": 20},
        {"day": "2022-08-11", "method": "stay", "hub": 1, "orders_due": 30, "delivered": 20},
    ]  # fmt: skip
    placed = [
        {"id": h, "center_lng": 121.4 + 0.1 * h, "center_lat": 31.2, "size_km": 10.0}
        for h in (0, 1)
    ]
    (out / "hub-2").mkdir(parents=True)
    (out / "hub-2" / "metrics.json").write_text(
        json.dumps({"days": [{"day": "2022-08-11", "method": "stay", "hub": 2}], "total": {}})
    )
    city = {"orders_due": 100, "delivered": 40, "hubs": "not a list"}
    doc = {"meta": {"hubs": placed}, "city": city, "days": days, "total": {"days": 2}}
    (out / "metrics.json").write_text(json.dumps(doc))
    (out / "left_out.csv").write_text(
        "day,order_id,row,lng,lat,reason\n"
        "2022-08-11,a,3,121.9,31.5,outside every hub\n"
        "2022-08-11,b,4,121.4,31.2,outside service hours\n"
        "2022-08-11,<c>,9,121.1,31.0,outside every hub\n"
    )
    invoke("report", out, "--quiet")
    html = (out / "report.html").read_text(encoding="utf-8")
    data, _ = figure(html, "city-map")
    assert [t["uid"] for t in data] == ["outside-hubs", "hub-0", "hub-1", "hubs"]
    # The orders outside every hub where they lie, each named (as text) on hover.
    assert (data[0]["x"], data[0]["y"]) == ([121.9, 121.1], [31.5, 31.0])
    assert data[0]["text"][1] == "order &lt;c&gt;, 2022-08-11: outside every hub"
    assert data[-1]["text"] == [
        "<b>hub 0</b><br>50 due<br>30 planned<br>20 delivered",
        "<b>hub 1</b><br>30 due<br>20 delivered",
    ]
    assert data[-1]["customdata"] == ["", ""]  # no hub-0/ nor hub-1/: no page to open
    assert "3 hubs: 100 orders due, 40 delivered (40.0 % of orders due)." in html
    assert "Not drawn (no square in their files): hubs 2." in html
    assert '<a href="hub-2/report.html">report</a>' in html


def test_the_city_map_names_an_order_id_longer_than_csvs_field_limit(tmp_path: Path) -> None:
    """An export's order id is text of any length, and left_out.csv holds it as it is: an
    id past the csv module's field limit (131,072 characters) ended the city's page, the
    run's own included, in a csv.Error traceback."""
    import csv

    from marops_cli.report.citymap import outside_hubs

    long = "L" * 140_000
    (tmp_path / "left_out.csv").write_text(
        "day,order_id,row,lng,lat,reason\n"
        f"2022-08-11,{long},3,121.9,31.5,outside every hub\n"
        "2022-08-11,b,4,121.4,31.2,outside service hours\n"
    )
    limit = csv.field_size_limit()
    lng, lat, text = outside_hubs(tmp_path)
    assert (lng, lat, text) == ([121.9], [31.5], [f"order {long}, 2022-08-11: outside every hub"])
    assert csv.field_size_limit() == limit  # the module's limit as it was


def test_the_city_map_draws_every_nth_order_outside_the_hubs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Past the most the map draws (lowered here to 10), every n-th of the orders outside
    every hub, in file order, the others' reasons skipped: 50 outside, so every 6th (0, 6,
    …, 48), counted in a first pass and read in a second, never all held at once."""
    import marops_cli.report.citymap as citymap

    monkeypatch.setattr(citymap, "MOST_LEFT_OUT", 10)
    lines = ["day,order_id,row,lng,lat,reason"]
    for k in range(50):
        lines.append(f"2022-08-11,o{k},{k + 2},{121 + k / 100},31.2,outside every hub")
        lines.append(f"2022-08-11,h{k},{k + 2},121.4,31.2,outside service hours")
    (tmp_path / "left_out.csv").write_text("\n".join(lines) + "\n")
    lng, _, text = citymap.outside_hubs(tmp_path)
    assert [t.split(",")[0] for t in text] == [f"order o{k}" for k in range(0, 50, 6)]
    assert lng == pytest.approx([121 + k / 100 for k in range(0, 50, 6)])


def test_the_city_map_draws_a_hub_with_nothing_due_that_day() -> None:
    """A hub of the city where no order was due on the day has no delivered share: its
    square is grey and the map is drawn (plotly refused the None among the colours, and a
    real city run's report failed)."""
    from marops_cli.data.frame import Frame
    from marops_cli.report.citymap import CityHub, city_map_figure

    busy = CityHub(0, Frame(121.40, 31.20, 10.0), {"orders_due": 40, "delivered": 30}, 8, "hub-0/")
    idle = CityHub(1, Frame(121.50, 31.20, 10.0), {"orders_due": 0, "delivered": 0}, 8, "hub-1/")
    fig = city_map_figure([busy, idle])
    (labels,) = [t for t in fig.data if t.name == "hubs"]
    assert list(labels.marker.color) == [0.75, 0.0]
    assert [t.line.color for t in fig.data if t.name == "hub 1"] == ["rgb(150,150,150)"]
