"""The report in a real browser (headless Chromium over the DevTools protocol): the map
holds one line per route, the page logs no error, and a screenshot is taken; the pages of
several days load the plotly.js they share from a file. Skipped only where no Chromium is
on PATH; .ci/run installs the distribution's package."""

from __future__ import annotations

import json
import os
import shutil
import struct
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from marops_cli.report.basemap import ATTRIBUTION, TILE_HOST

from .cdp import chromium, open_page
from .conftest import invoke, rewrite_parquet

pytestmark = pytest.mark.skipif(chromium() is None, reason="no chromium on PATH")

_MAP = "document.getElementById('map')"
READY = (
    f"typeof Plotly !== 'undefined' && !!{_MAP} && {_MAP}._fullLayout !== undefined"
    " && !!document.querySelector('#timeline .bars')"
)
ROUTE_LINES = "#map g.trace.scatter[class*='traceroute-'] path.js-line"


def _png_size(data: bytes) -> tuple[int, int]:
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


def test_report_in_chromium(day_run: Path, tmp_path: Path) -> None:
    shot = Path(os.environ.get("MAROPS_REPORT_SCREENSHOT", tmp_path / "report.png"))
    run = open_page(
        (day_run / "report.html").as_uri(),
        ready=READY,
        expressions={
            "drawn": f'document.querySelectorAll("{ROUTE_LINES}").length',
            "traces": f"{_MAP}.data.filter(t => (t.uid || '').startsWith('route-')).length",
            "slider": "document.querySelectorAll('#map .slider-container').length",
            "bars": "document.querySelectorAll('#timeline .bars .point').length",
            "buttons": "[...document.querySelectorAll('.modebar-btn')].map(b => b.dataset.title)",
        },
        screenshot=shot,
    )
    routes = pq.read_table(day_run / "routes.parquet").to_pylist()
    flown = sum(r["n_parcels"] > 0 or r["start_depot"] != r["end_depot"] for r in routes)
    assert run.values["traces"] == flown
    assert run.values["drawn"] == flown  # one drawn line per route
    assert run.values["slider"] == 1
    assert run.values["bars"] >= flown
    # The figures' buttons: none uploads the figure (plotly's "Share chart...").
    assert "Download plot as a PNG" in run.values["buttons"]
    assert not [b for b in run.values["buttons"] if "share" in b.lower() or "cloud" in b.lower()]
    # Offline the map tiles fail to load (the service areas stay the map); nothing else may.
    errors = [
        e
        for e in run.errors
        if not (e["source"] == "network" and str(e.get("url", "")).startswith(TILE_HOST))
    ]
    assert errors == []
    width, height = _png_size(shot.read_bytes())
    assert (width, height) == (1300, 1000)


# The slider dragged to its last window as a user does (a press on the rail at the last
# tick); resolves to the step the slider then shows, once the map is redrawn.
SLIDE_TO_LAST = """new Promise(done => {
  const ticks = document.querySelectorAll('#map .slider-tick-rect');
  const tick = ticks[ticks.length - 1].getBoundingClientRect();
  const at = {bubbles: true, view: window, clientX: tick.x + tick.width / 2,
              clientY: tick.y + tick.height / 2};
  document.querySelector('#map .slider-rail-touch-rect')
    .dispatchEvent(new MouseEvent('mousedown', at));
  document.getElementById('map').dispatchEvent(new MouseEvent('mouseup', at));
  document.getElementById('map').once('plotly_restyle',
    () => setTimeout(() => done(document.getElementById('map')._fullLayout.sliders[0].active)));
})"""
LEGEND = "[...document.querySelectorAll('#map .legendtext')].map(e => e.textContent)"
# The map's annotations as drawn, once the tile credit shows or after a while without.
CREDIT = """new Promise(done => {
  let waited = 0;
  const look = () => {
    const drawn = [...document.querySelectorAll('#map .annotation')].map(e => e.textContent);
    if (drawn.length || waited >= 5000) return done(drawn);
    waited += 100;
    setTimeout(look, 100);
  };
  look();
})"""
PIXEL = (
    "data:image/png;base64,iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNk"
    "+M9QDwADhgGAWjR9awAAAABJRU5ErkJggg=="
)


def test_the_drone_legend_stays_on_every_window_of_the_slider(
    day_run: Path, tmp_path: Path
) -> None:
    """Moved to a later window, the map's legend still names every drone that flies
    (only the routes of that window are drawn); offline no tile loads and no tile credit
    shows, and once a tile loads (a data: tile in a copy of the page) the credit does."""
    import re

    routes = pq.read_table(day_run / "routes.parquet").to_pylist()
    flown = [r for r in routes if r["n_parcels"] > 0 or r["start_depot"] != r["end_depot"]]
    last = max(r["window"] for r in flown)
    names = {f"drone {r['drone']} ({r['drone_type']})" for r in flown}
    run = open_page(
        (day_run / "report.html").as_uri(),
        ready=READY,
        expressions={
            "before": LEGEND,
            "step": SLIDE_TO_LAST,
            "after": LEGEND,
            "drawn": f"{_MAP}.data.filter(t => t.visible !== false && "
            "(t.uid || '').startsWith('route-')).map(t => t.uid)",
            "credit": CREDIT,
        },
    )
    assert run.values["step"] == len({r["window"] for r in routes})  # "all" is step 0
    assert {d.split("-")[1] for d in run.values["drawn"]} == {f"w{last}"}
    for when in ("before", "after"):
        assert {t for t in run.values[when] if t.startswith("drone ")} == names, when
    assert run.values["credit"] == []
    assert _offline_errors(run.errors) == []

    page = (day_run / "report.html").read_text(encoding="utf-8")
    tiles = re.sub(r'https:\\u002f\\u002fserver\.arcgisonline\.com[^"]*', PIXEL, page)
    assert tiles != page
    (tmp_path / "tiles.html").write_text(tiles, encoding="utf-8")
    run = open_page((tmp_path / "tiles.html").as_uri(), ready=READY, expressions={"credit": CREDIT})
    assert run.values["credit"] == [ATTRIBUTION]
    assert run.errors == []


def test_pages_sharing_plotly_js_draw_their_figures_from_files(
    days_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A day's page and the page over the days of a several-day run, opened from their
    files, load the shared plotly.js (the policy lets it in) and draw their figures:
    with map tiles (which fail offline, nothing else may) and without (nothing fails)."""
    from marops_cli.report.page import script_name

    assert (days_run / script_name()).is_file()
    day = days_run / "2022-08-11"
    drawn = {
        "plotly": "typeof Plotly",
        "svgs": "[...document.querySelectorAll('.js-plotly-plot')]"
        ".map(d => [d.id, d.querySelectorAll('svg.main-svg').length])",
        "lines": f'document.querySelectorAll("{ROUTE_LINES}").length',
    }
    routes = pq.read_table(day / "routes.parquet").to_pylist()
    flown = sum(r["n_parcels"] > 0 or r["start_depot"] != r["end_depot"] for r in routes)
    run = open_page((day / "report.html").as_uri(), ready=READY, expressions=drawn)
    assert run.values["plotly"] == "object"
    assert dict(run.values["svgs"]).keys() == {"map", "timeline"}
    assert all(n > 0 for _, n in run.values["svgs"])
    assert run.values["lines"] == flown
    assert _offline_errors(run.errors) == []

    copy = tmp_path / "off"
    shutil.copytree(days_run, copy)
    monkeypatch.setenv("MAROPS_TILES", "off")
    invoke("report", copy, "--quiet")
    assert "<script src=" in (copy / "2022-08-11" / "report.html").read_text(encoding="utf-8")
    run = open_page((copy / "2022-08-11" / "report.html").as_uri(), ready=READY, expressions=drawn)
    assert run.values["lines"] == flown and run.errors == []
    top = "typeof Plotly !== 'undefined' && !!document.querySelector('#days svg.main-svg')"
    run = open_page((copy / "report.html").as_uri(), ready=top, expressions=drawn)
    assert run.values["svgs"][0][0] == "days" and run.values["svgs"][0][1] > 0
    assert run.errors == []


def _offline_errors(errors: list[dict]) -> list[dict]:
    """What the page logged but the failed tile loads (offline they must fail)."""
    return [
        e
        for e in errors
        if not (e["source"] == "network" and str(e.get("url", "")).startswith(TILE_HOST))
    ]


def test_odd_names_show_as_text_and_leave_the_map_its_width(day_run: Path, tmp_path: Path) -> None:
    """A drone type that looks like HTML and runs long, a method name without a space:
    the legend shows the characters (cut short, so the map keeps its width), nothing
    on the page becomes a link, and the page does not grow wider than the window."""
    copy = tmp_path / "odd"
    shutil.copytree(day_run, copy)
    kind = "<b>heavy</b> " + "T" * 300
    rewrite_parquet(copy / "routes.parquet", "drone_type", lambda v: kind, method="M" * 400)
    odd = {"method": "M" * 400}  # the run's every file names it (report checks one run)
    rewrite_parquet(
        copy / "stops.parquet", "order_id", lambda v: v and f"<a href='x'>{v}</a>", **odd
    )
    doc = json.loads((copy / "metrics.json").read_text(encoding="utf-8"))
    (copy / "metrics.json").write_text(json.dumps({**doc, "meta": {**doc["meta"], **odd}}))
    invoke("report", copy, "--quiet")
    run = open_page(
        (copy / "report.html").as_uri(),
        ready=READY,
        expressions={
            # What a script slipped into the page would do to send the data away: the
            # page's policy lets it load nothing but the map tiles.
            "leak": "(new Image()).src = 'https://example.invalid/leak.png'",
            "legend": "[...document.querySelectorAll('#map .legendtext')].map(e => e.textContent)",
            "links": "document.querySelectorAll('a').length",
            "plot": f"+{_MAP}.querySelector('.nsewdrag').getAttribute('width')",
            "page": "document.documentElement.scrollWidth - window.innerWidth",
        },
    )
    drones = [t for t in run.values["legend"] if t.startswith("drone ")]
    assert drones and all(t.endswith(" (<b>heavy</b> TTTTTTTTTTTTTTTTTTTTTTTTTT…)") for t in drones)
    assert run.values["links"] == 0
    assert run.values["plot"] > 400  # the legend left the map its width
    assert run.values["page"] <= 0  # the long title wraps
    blocked = [e for e in run.errors if "example.invalid" in e["text"]]
    assert blocked and all(e["source"] == "security" for e in blocked), run.errors
    assert "Content Security Policy" in blocked[0]["text"]
    assert [e for e in _offline_errors(run.errors) if e not in blocked] == []


def test_the_frontier_chart_draws_a_line_per_method_in_chromium(evaluation_run: Path) -> None:
    """An evaluation over two values of α: the frontier chart draws in the browser, one
    line per method in each of its two panels, a marker per α, and the page logs no
    error."""
    ready = "typeof Plotly !== 'undefined' && !!document.querySelector('#frontier svg.main-svg')"
    run = open_page(
        (evaluation_run / "report.html").as_uri(),
        ready=ready,
        expressions={
            "traces": "document.getElementById('frontier').data.length",
            "points": "document.querySelectorAll('#frontier g.trace.scatter path.point').length",
            "legend": "[...document.querySelectorAll('#frontier .legendtext')]"
            ".map(e => e.textContent)",
        },
    )
    assert run.values["traces"] == 4  # stay and greedy, in each panel
    assert run.values["points"] == 8  # two values of α each
    assert sorted(run.values["legend"]) == ["greedy", "stay"]
    assert _offline_errors(run.errors) == []


CITY_READY = "typeof Plotly !== 'undefined' && !!document.querySelector('#city-map svg.main-svg')"
# A click on hub 1's label as a user makes it (the pointer moved there, pressed and
# released): resolves to what plotly says was clicked, the hub's link.
CLICK_HUB_1 = """new Promise(done => {
  const gd = document.getElementById('city-map');
  const labels = gd.data.find(t => t.uid === 'hubs');
  const i = labels.customdata.findIndex(h => h === 'hub-1/report.html');
  const size = gd._fullLayout._size, box = gd.getBoundingClientRect();
  const at = {bubbles: true, view: window,
    clientX: box.x + size.l + gd._fullLayout.xaxis.d2p(labels.x[i]),
    clientY: box.y + size.t + gd._fullLayout.yaxis.d2p(labels.y[i])};
  gd.on('plotly_click', e => done(e.points[0].customdata));
  const drag = gd.querySelector('.nsewdrag');
  drag.dispatchEvent(new MouseEvent('mousemove', at));
  drag.dispatchEvent(new MouseEvent('mousedown', at));
  drag.dispatchEvent(new MouseEvent('mouseup', at));
  document.dispatchEvent(new MouseEvent('mouseup', at));
})"""


def test_the_city_page_opens_on_its_hubs_map_and_a_click_opens_a_hub(city_run: Path) -> None:
    """A city run's page draws every hub's square on the map with its label (orders due,
    planned, delivered from the city's metrics.json); a click on a hub opens its page,
    and that page links back up to the city's."""
    run = open_page(
        (city_run / "report.html").as_uri(),
        ready=CITY_READY,
        expressions={
            "squares": "document.getElementById('city-map').data"
            ".filter(t => (t.uid || '').startsWith('hub-')).map(t => t.uid)",
            "fills": "document.querySelectorAll('#city-map g.trace.scatter path.js-fill').length",
            "labels": "[...document.querySelectorAll('#city-map g.textpoint text')]"
            ".map(e => e.textContent)",
            "clicked": CLICK_HUB_1,
        },
        follow=True,
    )
    assert run.values["squares"] == ["hub-0", "hub-1", "hub-2"]
    assert run.values["fills"] == 3
    for h, label in enumerate(run.values["labels"]):
        day = json.loads((city_run / f"hub-{h}" / "metrics.json").read_text())["days"][0]
        due, planned, delivered = (day[k] for k in ("orders_due", "requests", "delivered"))
        assert label == f"hub {h}{due} due{planned} planned{delivered} delivered"
    assert run.values["clicked"] == "hub-1/report.html"
    assert run.url == (city_run / "hub-1" / "report.html").as_uri()
    assert _offline_errors(run.errors) == []

    up = "document.querySelector('p.note a')"
    run = open_page(
        (city_run / "hub-1" / "report.html").as_uri(),
        ready=READY,
        expressions={"href": f"{up}.getAttribute('href')", "click": f"{up}.click()"},
        follow=True,
    )
    assert run.values["href"] == "../report.html"
    assert run.url == (city_run / "report.html").as_uri()
    assert _offline_errors(run.errors) == []
