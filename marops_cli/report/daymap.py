"""The day's interactive map: service areas, depots, each drone's routes in its own
colour (one line per route), the stops' times, weights and delays on hover, and a slider
over the windows."""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence
from typing import Any

from ..data.frame import Frame
from .basemap import ATTRIBUTION, extent, tile_images, tiles_on
from .folder import RouteFiles, flown
from .page import plain, short

ROUTE_UID = "route-w{window}-d{drone}"
"""The uid of a route's trace: one trace (one line) per route flown."""
LEGEND_UID = "drone-d{drone}"
"""The uid of a drone's legend entry: a trace without points, shown in every window."""
DEPOT_COLOUR = "#222222"  # black squares: apart from every drone colour
TILE_CREDIT = "tile-credit"
"""The name of the map's annotation that credits the tiles."""
TILE_CREDIT_SCRIPT = """
var gd = document.getElementById('{plot_id}');
var credit = (gd.layout.annotations || []).findIndex(function (a) {
  return a.name === '{credit}';
});
var shown = false;
(gd.layout.images || []).forEach(function (im) {
  var tile = new Image();
  tile.onload = function () {
    if (shown || credit < 0) return;
    shown = true;
    var show = {};
    show['annotations[' + credit + '].visible'] = true;
    Plotly.relayout(gd, show);
  };
  tile.src = im.source;
});
""".replace("{credit}", TILE_CREDIT)
"""Run after the map is drawn (plotly's ``post_script``): the tiles' credit shows once a
tile has loaded, never on a map without tiles (offline)."""
WINDOW_SLIDER_SCRIPT = """
var gd = document.getElementById('{plot_id}');
gd.on('plotly_sliderchange', function (e) {
  var w = e.step.value;
  Plotly.restyle(gd, {visible: gd.data.map(function (t) {
    var route = /^route-w(\\d+)-d/.exec(t.uid || '');
    return !route || w === 'all' || route[1] === w;
  })});
});
"""
"""Run after the map is drawn (plotly's ``post_script``): the slider's step (its
``value``: ``all``, or a window's number) shows every trace but the routes of other
windows (a route's trace is named by its uid, :data:`ROUTE_UID`). Worked out here from
the step, the page holds no list of every trace per window: it grew with windows times
routes (a day of 96 windows and 3,000 routes held 288,000 flags)."""


def drone_colour(drone: int) -> str:
    """A drone's colour on the map and the timeline."""
    from plotly.colors import qualitative

    palette = qualitative.Plotly if drone < 10 else qualitative.Dark24
    return palette[drone % len(palette)]


def route_stops(files: RouteFiles) -> dict[tuple[int, int], list[dict[str, Any]]]:
    """Each (window, drone)'s stops in visiting order."""
    by: dict[tuple[int, int], list[dict[str, Any]]] = defaultdict(list)
    for s in files.stops:
        by[(s["window"], s["drone"])].append(s)
    return {k: sorted(v, key=lambda s: s["seq"]) for k, v in by.items()}


def _hover(s: dict[str, Any]) -> str:
    at = s["arrive_time"].strftime("%H:%M:%S")
    depot = plain(s["depot"])
    if s["kind"] == "start":
        return f"takes off from depot {depot} at {at}<br>{s['payload_kg']:.2f} kg on board"
    if s["kind"] == "end":
        return f"lands at depot {depot} at {at}"
    return (
        f"order {plain(s['order_id'])}<br>arrives {at}<br>{s['weight_kg']:.2f} kg, "
        f"delay {s['delay_h']:.2f} h (due in window {plain(s['due_window'])})"
    )


def map_figure(
    files: RouteFiles,
    depots: dict[int, tuple[float, float]],
    areas: Sequence[tuple[int, list[float], list[float]]],
    frame: Frame | None,
) -> Any:
    """The map (a plotly figure on longitude/latitude axes, drawn as SVG: nothing to
    fetch but the tiles)."""
    import plotly.graph_objects as go

    fig = go.Figure()
    for n, (depot, lng, lat) in enumerate(areas):
        fig.add_trace(
            go.Scatter(
                x=lng,
                y=lat,
                mode="lines",
                fill="toself",
                fillcolor="rgba(120,120,120,0.07)",
                line={"color": "rgba(80,80,80,0.55)", "width": 1},
                hoveron="fills",
                hoverinfo="text",
                text=f"service area of depot {plain(depot)}",
                name="service areas",
                legendgroup="areas",
                showlegend=n == 0,
            )
        )
    ids = sorted(depots)
    fig.add_trace(
        go.Scatter(
            x=[depots[i][0] for i in ids],
            y=[depots[i][1] for i in ids],
            mode="markers",
            marker={"symbol": "square", "size": 10, "color": DEPOT_COLOUR},
            text=[f"depot {plain(i)}" for i in ids],
            hovertemplate="%{text}<extra></extra>",
            name="depots",
        )
    )
    stops = route_stops(files)
    windows = sorted({r["window"] for r in files.routes})
    drawn = sorted((r for r in files.routes if flown(r)), key=lambda r: (r["drone"], r["window"]))
    # The legend: an entry per drone that flies, drawn by a trace of its own that no
    # window of the slider hides (a route's trace carries none: the slider hides the
    # routes of the other windows, and their entries with them). Clicking an entry
    # hides or shows the drone's routes (its legend group).
    first: dict[int, dict[str, Any]] = {}
    for r in drawn:
        first.setdefault(r["drone"], r)
    for d, r in first.items():
        fig.add_trace(
            go.Scatter(
                x=[None],
                y=[None],
                mode="lines+markers",
                line={"color": drone_colour(d), "width": 2},
                marker={"size": 7, "color": drone_colour(d)},
                hoverinfo="skip",
                name=f"drone {plain(d)} ({plain(short(r['drone_type']))})",
                legendgroup=f"drone {d}",
                uid=LEGEND_UID.format(drone=d),
            )
        )
    for r in drawn:
        d, w = r["drone"], r["window"]
        pts = stops[(w, d)]
        fig.add_trace(
            go.Scatter(
                x=[s["lng"] for s in pts],
                y=[s["lat"] for s in pts],
                mode="lines+markers",
                line={"color": drone_colour(d), "width": 2},
                marker={
                    "size": [0 if s["kind"] != "customer" else 7 for s in pts],
                    "color": drone_colour(d),
                },
                text=[_hover(s) for s in pts],
                hovertemplate=f"%{{text}}<extra>drone {plain(d)}, window {plain(w)}</extra>",
                name=f"drone {plain(d)} ({plain(short(r['drone_type']))})",
                legendgroup=f"drone {d}",
                showlegend=False,
                uid=ROUTE_UID.format(window=w, drone=d),
            )
        )
    _window_slider(fig, windows, files)
    map_axes(fig, frame, depots)
    return fig


def _window_slider(fig: Any, windows: list[int], files: RouteFiles) -> None:
    """A slider: every window's routes, or one window's (:data:`WINDOW_SLIDER_SCRIPT`)."""
    if len(windows) < 2:
        return
    starts = {r["window"]: r["window_start"] for r in files.routes}
    # Each step only names what it shows; WINDOW_SLIDER_SCRIPT shows it ("skip": the
    # slider itself changes no trace).
    steps = [{"label": "all", "value": "all", "method": "skip"}]
    for w in windows:
        label = f"{plain(w)} {starts[w].strftime('%H:%M')}"
        steps.append({"label": label, "value": str(w), "method": "skip"})
    fig.update_layout(
        sliders=[
            {
                "active": 0,
                "currentvalue": {"prefix": "window: "},
                "pad": {"t": 30},
                "steps": steps,
            }
        ]
    )


def map_axes(fig: Any, frame: Frame | None, depots: dict[int, tuple[float, float]]) -> None:
    """Longitude and latitude at the same ground scale; the tiles below when a frame
    places them."""
    lat0 = frame.center_lat if frame is not None else _mean([p[1] for p in depots.values()])
    fig.update_layout(
        height=720,
        margin={"l": 60, "r": 20, "t": 40, "b": 40},
        plot_bgcolor="white",
        hovermode="closest",
        legend={"itemsizing": "constant"},
        xaxis={"title": "longitude (°)", "showgrid": False, "zeroline": False},
        yaxis={
            "title": "latitude (°)",
            "showgrid": False,
            "zeroline": False,
            "scaleanchor": "x",
            "scaleratio": 1.0 / math.cos(math.radians(lat0)),
        },
    )
    if frame is None:
        return
    west, south, east, north = extent(frame)
    fig.update_layout(xaxis={"range": [west, east]}, yaxis={"range": [south, north]})
    if not tiles_on():
        return
    fig.update_layout(
        images=tile_images(frame),
        annotations=[
            {
                # Hidden until a tile has loaded (TILE_CREDIT_SCRIPT): offline the map
                # has no tiles, and credits none.
                "name": TILE_CREDIT,
                "visible": False,
                "text": ATTRIBUTION,
                "xref": "paper",
                "yref": "paper",
                "x": 1.0,
                "y": 0.0,
                "xanchor": "right",
                "yanchor": "bottom",
                "showarrow": False,
                "font": {"size": 9, "color": "#555"},
                "bgcolor": "rgba(255,255,255,0.7)",
            }
        ],
    )


def _mean(values: list[float]) -> float:
    return sum(values) / len(values) if values else 0.0
