"""The city's map on a city run's page (docs/report.md): every hub's square on the map,
coloured by the share of its orders due that were delivered and labelled with its
orders due, planned and delivered; a click on a hub opens its page."""

from __future__ import annotations

import itertools
import math
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import quote

import numpy as np

from ..data.frame import Frame
from .basemap import tiles_on
from .daymap import TILE_CREDIT_SCRIPT, map_axes
from .folder import REPORT, metrics
from .page import Page, plain

HUB_UID = "hub-{hub}"
"""The uid of a hub's square on the city's map (a filled outline)."""
HUBS_UID = "hubs"
"""The uid of the trace of the hubs' labels (a marker at each square's centre)."""
FIGURES = (("orders_due", "due"), ("planned", "planned"), ("delivered", "delivered"))
"""A hub's figures on the map and in the table, from the city's ``metrics.json``."""
OPEN_HUB_SCRIPT = """
var gd = document.getElementById('{plot_id}');
gd.on('plotly_click', function (e) {
  var p = e && e.points && e.points[0];
  var href = p && p.customdata;
  if (typeof href === 'string' && href) window.location.href = href;
});
"""
"""Run after the map is drawn: a click on a hub's label opens its page (a link plotly
would draw in a figure's text is dropped from a page opened from a file)."""


@dataclass(frozen=True)
class CityHub:
    """A hub as the city's page shows it: its square (None where no file names it), its
    figures (those the files hold) and the link to its page ("" where it has none)."""

    hub: int
    frame: Frame | None
    figures: dict[str, int]
    drones: int | None
    href: str


def city_hubs(folder: Path, doc: dict[str, Any]) -> list[CityHub]:
    """Every hub of the city run in ``folder`` (its ``metrics.json`` is ``doc``): those
    its ``city`` block, its days and ``meta.hubs`` name, and the ``hub-<id>`` folders,
    in id order."""
    city, meta = (_mapping(doc.get(k)) for k in ("city", "meta"))
    rows = {r["hub"]: r for r in _records(city.get("hubs")) if _whole(r.get("hub")) is not None}
    days = [d for d in _records(doc.get("days")) if _whole(d.get("hub", 0)) is not None]
    placed = {h["id"]: h for h in _records(meta.get("hubs")) if _whole(h.get("id")) is not None}
    ids = set(rows) | {d.get("hub", 0) for d in days} | set(placed)
    ids |= {int(p.name[4:]) for p in _hub_folders(folder)}
    hubs = []
    for h in sorted(ids):
        sub = folder / f"hub-{h}"
        mine = [d for d in days if d.get("hub", 0) == h]
        hubs.append(
            CityHub(
                h,
                _square(placed.get(h)) or _hub_square(sub),
                _figures(rows.get(h), mine),
                _whole(rows.get(h, {}).get("drones")),
                _href(sub),
            )
        )
    return hubs


def _mapping(value: Any) -> dict[str, Any]:
    return value if isinstance(value, dict) else {}


def _records(value: Any) -> list[dict[str, Any]]:
    return [r for r in value if isinstance(r, dict)] if isinstance(value, list) else []


def _hub_folders(folder: Path) -> list[Path]:
    return [
        p
        for p in folder.glob("hub-*")
        if p.name[4:].isdigit() and p.name[4:] == str(int(p.name[4:])) and p.is_dir()
    ]


def _whole(value: Any) -> int | None:
    """A count as the files hold it, or None for anything else."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return int(value) if math.isfinite(value) and value == int(value) else None


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None


def _figures(row: dict[str, Any] | None, days: list[dict[str, Any]]) -> dict[str, int]:
    """A hub's orders due, planned and delivered: its row of the city block, else the sum
    over its days (a day's ``requests`` are its planned orders); a figure missing from the
    files is left out."""
    if row is not None:
        found = {k: _whole(row.get(k)) for k, _ in FIGURES}
        return {k: v for k, v in found.items() if v is not None}
    out: dict[str, int] = {}
    for key, day_key in (("orders_due", "orders_due"), ("planned", "requests")):
        values = [_whole(d.get(day_key)) for d in days]
        if days and None not in values:
            out[key] = sum(v for v in values if v is not None)
    values = [_whole(d.get("delivered")) for d in days]
    if days and None not in values:
        out["delivered"] = sum(v for v in values if v is not None)
    return out


def _square(doc: Any) -> Frame | None:
    """A square (``center_lng``, ``center_lat``, ``size_km``) as the files name it."""
    if not isinstance(doc, dict):
        return None
    lng, lat = _number(doc.get("center_lng")), _number(doc.get("center_lat"))
    size = _number(doc.get("size_km"))
    if lng is None or lat is None or size is None:
        return None
    if not (-180 <= lng <= 180 and -90 <= lat <= 90 and 0 < size <= 200):
        return None
    return Frame(lng, lat, size)


def _hub_square(sub: Path) -> Frame | None:
    """A hub's square from its folder's ``metrics.json``: the day's frame, or (over
    several days) the centre and size of its settings."""
    if not sub.is_dir():
        return None
    doc = metrics(sub)
    meta = doc.get("meta") if isinstance(doc, dict) else None
    if not isinstance(meta, dict):
        return None
    found = _square(meta.get("frame"))
    if found is not None:
        return found
    config = meta.get("config")
    data = config.get("data") if isinstance(config, dict) else None
    if not isinstance(data, dict):
        return None
    center = data.get("center")
    if not (isinstance(center, list) and len(center) == 2):
        return None
    lng, lat = center
    return _square({"center_lng": lng, "center_lat": lat, "size_km": data.get("size_km")})


def _href(sub: Path) -> str:
    """The hub's page relative to the city's, percent-encoded ("" where it has none)."""
    if (sub / REPORT).is_file() or (sub / "metrics.json").is_file():
        return quote(os.fsencode(f"{sub.name}/{REPORT}"))
    return ""


def delivered_of_due(h: CityHub) -> float | None:
    due, delivered = h.figures.get("orders_due"), h.figures.get("delivered")
    return delivered / due if due and delivered is not None else None


def _label(h: CityHub) -> str:
    figures = [f"{h.figures[k]:,} {name}" for k, name in FIGURES if k in h.figures]
    return "<br>".join([f"<b>hub {h.hub}</b>", *figures])  # short lines: a square's width


def _hover(h: CityHub) -> str:
    lines = [f"hub {h.hub}" + (f", {h.drones} drones" if h.drones is not None else "")]
    lines += [f"{h.figures[k]:,} orders {name}" for k, name in FIGURES if k in h.figures]
    share = delivered_of_due(h)
    if share is not None:
        lines.append(f"{100 * share:.1f} % of its orders due delivered")
    if h.href:
        lines.append("click to open its page")
    return "<br>".join(plain(line) for line in lines)


def _ring(frame: Frame) -> tuple[np.ndarray, np.ndarray]:
    h = frame.half_m
    x = np.array([-h, h, h, -h, -h])
    y = np.array([-h, -h, h, h, -h])
    return frame.to_lnglat(x, y)


def city_frame(frames: list[Frame]) -> Frame:
    """A square holding every hub's square, with a margin: the map's extent."""
    ref = frames[0]
    xs, ys = [], []
    for f in frames:
        x, y = ref.to_xy(*_ring(f))
        xs += [x.min(), x.max()]
        ys += [y.min(), y.max()]
    cx, cy = (min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2
    lng, lat = ref.to_lnglat(np.array([cx]), np.array([cy]))
    side_km = max(max(xs) - min(xs), max(ys) - min(ys)) / 1000.0
    return Frame(float(lng[0]), float(lat[0]), side_km * 1.08)


SCALE = "RdYlGn"
"""The hubs' colours: the share of their orders due delivered, red (none) to green (all)."""


LEFT_OUT = "left_out.csv"
"""The city run's orders no hub planned (docs/outputs.md, "Hubs")."""
OUTSIDE = "outside every hub"
LeftOut = tuple[list[float], list[float], list[str]]
"""Orders outside every hub: longitudes, latitudes, hover texts."""
MOST_LEFT_OUT = 20_000
"""The most orders outside every hub the map draws (every n-th of more, in file order)."""


def outside_hubs(folder: Path) -> LeftOut:
    """The orders of ``left_out.csv`` outside every hub: longitudes, latitudes and their
    hover texts (none where the file is absent or holds no such columns)."""
    import csv

    path = folder / LEFT_OUT
    if not path.is_file():
        return [], [], []
    # An order id is the export's text, of any length: a field longer than csv's limit
    # of 131,072 characters, which marops wrote, ended the page in a csv.Error.
    limit = csv.field_size_limit()
    csv.field_size_limit(max(limit, min(path.stat().st_size, 2**31 - 1)))  # a C long

    def outside() -> Iterator[dict[str, str]]:
        with path.open(encoding="utf-8", errors="replace", newline="") as fh:
            yield from (r for r in csv.DictReader(fh) if r.get("reason") == OUTSIDE)

    try:
        # Counted first, then every n-th read: a city's months may leave millions out,
        # and only :data:`MOST_LEFT_OUT` of them are ever held.
        step = sum(1 for _ in outside()) // MOST_LEFT_OUT + 1
        rows = list(itertools.islice(outside(), 0, None, step))
    finally:
        csv.field_size_limit(limit)
    lng, lat, text = [], [], []
    for r in rows:
        try:
            x, y = float(r["lng"]), float(r["lat"])
        except (KeyError, TypeError, ValueError):
            continue
        if math.isfinite(x) and math.isfinite(y):
            lng.append(x)
            lat.append(y)
            text.append(
                f"order {plain(r.get('order_id', ''))}, {plain(r.get('day', ''))}: {OUTSIDE}"
            )
    return lng, lat, text


def city_map_figure(hubs: list[CityHub], left_out: LeftOut | None = None) -> Any:
    """The city's map: a filled square per hub, a label at its centre (a click opens the
    hub's page), the orders ``left_out`` outside every hub (longitudes, latitudes, hover
    texts), on the map tiles of the city where the browser is online."""
    import plotly.graph_objects as go
    from plotly.colors import sample_colorscale

    drawn = [h for h in hubs if h.frame is not None]
    fig = go.Figure()
    outside = left_out or ([], [], [])
    if outside[0]:
        fig.add_trace(
            go.Scatter(
                x=outside[0],
                y=outside[1],
                mode="markers",
                marker={"size": 4, "color": "rgba(60,60,60,0.6)"},
                text=outside[2],
                hovertemplate="%{text}<extra></extra>",
                name=f"orders {OUTSIDE}",
                uid="outside-hubs",
            )
        )
        fig.update_layout(
            legend={"x": 0.0, "y": 1.0, "xanchor": "left", "bgcolor": "rgba(255,255,255,0.8)"}
        )
    for h in drawn:
        assert h.frame is not None
        lng, lat = _ring(h.frame)
        share = delivered_of_due(h)
        colour = sample_colorscale(SCALE, [share])[0] if share is not None else "rgb(150,150,150)"
        fig.add_trace(
            go.Scatter(
                x=[float(v) for v in lng],
                y=[float(v) for v in lat],
                mode="lines",
                fill="toself",
                fillcolor=colour.replace("rgb(", "rgba(").replace(")", ",0.35)"),
                line={"color": colour, "width": 2},
                hoveron="fills",
                hoverinfo="text",
                text=_hover(h),
                name=f"hub {h.hub}",
                showlegend=False,
                uid=HUB_UID.format(hub=h.hub),
            )
        )
    # The labels' invisible markers carry the colour bar: a hub with nothing due that
    # day has no share, and plotly takes no None among a marker's colours.
    shares = [0.0 if s is None else s for s in map(delivered_of_due, drawn)]
    fig.add_trace(
        go.Scatter(
            x=[h.frame.center_lng for h in drawn if h.frame is not None],
            y=[h.frame.center_lat for h in drawn if h.frame is not None],
            mode="markers+text",
            text=[_label(h) for h in drawn],
            textposition="middle center",
            textfont={"size": 10, "color": "#111"},
            hovertext=[_hover(h) for h in drawn],
            hovertemplate="%{hovertext}<extra></extra>",
            customdata=[h.href for h in drawn],
            marker={
                "size": 14,
                "symbol": "circle",
                "opacity": 0.0,  # the label is the target; the square shows the colour
                "color": shares,
                "colorscale": SCALE,
                "cmin": 0.0,
                "cmax": 1.0,
                "showscale": True,
                "colorbar": {"title": {"text": "delivered<br>of due"}, "tickformat": ".0%"},
            },
            name="hubs",
            showlegend=False,
            uid=HUBS_UID,
        )
    )
    map_axes(fig, city_frame([h.frame for h in drawn if h.frame is not None]), {})
    return fig


def city_section(page: Page, folder: Path, doc: dict[str, Any]) -> None:
    """The top of a city run's page: the city's figures in a line, the map of its hubs
    and the table of hubs, each linking its page."""
    city = _mapping(doc.get("city"))
    hubs = city_hubs(folder, doc)
    page.heading("The city")
    line = _city_line(city, len(hubs))
    if line:
        page.note(line)
    drawn = [h for h in hubs if h.frame is not None]
    if drawn:
        left_out = outside_hubs(folder)
        missing = ", ".join(str(h.hub) for h in hubs if h.frame is None)
        page.note(
            "Each hub's square coloured by the share of its orders due that were delivered, "
            "labelled with its orders due, planned and delivered; click a hub's label to "
            "open its page. "
            + (f"Grey dots: the orders {OUTSIDE} ({LEFT_OUT}). " if left_out[0] else "")
            + (
                "Map tiles appear when the browser is online."
                if tiles_on()
                else "MAROPS_TILES=off: no tiles fetched."
            )
            + (f" Not drawn (no square in their files): hubs {missing}." if missing else "")
        )
        fig = city_map_figure(hubs, left_out)
        script = OPEN_HUB_SCRIPT + (TILE_CREDIT_SCRIPT if fig.layout.images else "")
        page.figure(fig, "city-map", script)
    if hubs:
        page.heading("Hubs")
        header = ["hub", "drones", *(f"orders {n}" for _, n in FIGURES)]
        header += ["delivered of due", "report"]
        rows = []
        for h in hubs:
            share = delivered_of_due(h)
            cells: list[Any] = [h.hub, "" if h.drones is None else h.drones]
            cells += [h.figures.get(k, "") for k, _ in FIGURES]
            cells.append(f"{100 * share:.1f} %" if share is not None else "")
            cells.append(("report", h.href) if h.href else "")
            rows.append(cells)
        page.table(header, rows, links=len(header) - 1)


def _city_line(city: dict[str, Any], n_hubs: int) -> str:
    """The city's figures in a line, every share of all orders due; those its
    ``metrics.json`` leaves out are left out here."""
    due = _whole(city.get("orders_due"))
    parts = []
    for key, name in (("planned", "planned"), ("delivered", "delivered")):
        n = _whole(city.get(key))
        if n is not None:
            share = f" ({100 * n / due:.1f} % of orders due)" if due else ""
            parts.append(f"{n:,} {name}{share}")
    left = []
    for key, name in (
        ("outside_hubs", "outside every hub"),
        ("outside_hours", "due outside service hours"),
    ):
        n = _whole(city.get(key))
        if n:
            left.append(f"{n:,} {name}")
    head = f"{n_hubs} hub{'s' * (n_hubs != 1)}"
    if due is not None:
        head += f": {due:,} orders due"
    text = head + (", " + ", ".join(parts) if parts else "")
    return text + (f"; left out: {', '.join(left)}" if left else "") + "."
