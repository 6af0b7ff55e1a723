"""The drones' day as a timeline: when each flies (take-off to landing, where it lands)
and when it waits at a depot."""

from __future__ import annotations

import datetime as dt
from typing import Any

from .daymap import drone_colour, flown, route_stops
from .folder import RouteFiles
from .page import plain

_WAIT_COLOUR = "rgba(150,150,150,0.35)"


def window_length(files: RouteFiles) -> dt.timedelta:
    """The windows' length: between consecutive window starts, else the config's."""
    starts = sorted({r["window_start"] for r in files.routes})
    gaps = [b - a for a, b in zip(starts, starts[1:], strict=False) if b > a]
    if gaps:
        return min(gaps)
    data = files.meta.get("config", {}).get("data", {})
    if data.get("window_min"):
        return dt.timedelta(minutes=float(data["window_min"]))
    if data.get("windows"):
        t0, t1 = (dt.datetime.strptime(data[k], "%H:%M") for k in ("service_start", "service_end"))
        return (t1 - t0) / int(data["windows"])
    return dt.timedelta(minutes=30)


def timeline_figure(files: RouteFiles) -> Any:
    """A Gantt chart: a bar per flight in the drone's colour, grey bars for windows spent
    waiting at a depot; hover tells take-off, landing and where."""
    import plotly.graph_objects as go

    stops = route_stops(files)
    length = window_length(files)
    ms = 1000.0
    flights: dict[int, dict[str, list[Any]]] = {}
    waits: dict[str, list[Any]] = {"base": [], "x": [], "y": [], "text": []}
    for r in sorted(files.routes, key=lambda r: (r["drone"], r["window"])):
        d, w, start = r["drone"], r["window"], r["window_start"]
        label = f"drone {plain(d)}"
        if not flown(r):
            waits["base"].append(_iso(start))
            waits["x"].append(length.total_seconds() * ms)
            waits["y"].append(label)
            waits["text"].append(f"window {plain(w)}: waits at depot {plain(r['start_depot'])}")
            continue
        pts = stops[(w, d)]
        seconds = max(s["arrive_s"] for s in pts)
        land = start + dt.timedelta(seconds=seconds)
        bars = flights.setdefault(d, {"base": [], "x": [], "y": [], "text": [], "hover": []})
        bars["base"].append(_iso(start))
        bars["x"].append(seconds * ms)
        bars["y"].append(label)
        bars["text"].append(f"→{plain(r['end_depot'])}")
        bars["hover"].append(
            f"window {plain(w)}: depot {plain(r['start_depot'])} {start:%H:%M:%S} → depot "
            f"{plain(r['end_depot'])} {land:%H:%M:%S}<br>{plain(r['n_parcels'])} parcels, "
            f"{r['distance_m'] / 1000:.2f} km, {r['energy_j'] / 1000:.1f} kJ "
            f"({100 * r['battery_frac']:.0f} % of the battery)"
        )
    fig = go.Figure()
    if waits["y"]:
        fig.add_trace(
            go.Bar(
                orientation="h",
                base=waits["base"],
                x=waits["x"],
                y=waits["y"],
                hovertext=waits["text"],
                hoverinfo="text",
                marker={"color": _WAIT_COLOUR},
                name="waits at a depot",
            )
        )
    for d, bars in sorted(flights.items()):
        fig.add_trace(
            go.Bar(
                orientation="h",
                base=bars["base"],
                x=bars["x"],
                y=bars["y"],
                text=bars["text"],
                textposition="inside",
                insidetextanchor="middle",
                textangle=0,
                hovertext=bars["hover"],
                hoverinfo="text",
                marker={"color": drone_colour(d)},
                name=f"drone {plain(d)} flies",
                legendgroup=f"drone {d}",
            )
        )
    drones = sorted({r["drone"] for r in files.routes})
    fig.update_layout(
        barmode="overlay",
        height=max(260, 36 * len(drones) + 120),
        margin={"l": 80, "r": 20, "t": 30, "b": 40},
        xaxis={
            "type": "date",
            "title": "local time",
            # Ticks less than a minute apart (one short window) show their seconds, or
            # two ticks would read the same.
            "tickformatstops": [
                {"dtickrange": [None, 60_000], "value": "%H:%M:%S"},
                {"dtickrange": [60_000, None], "value": "%H:%M"},
            ],
        },
        yaxis={
            "categoryorder": "array",
            "categoryarray": [f"drone {plain(d)}" for d in reversed(drones)],
        },
        uniformtext={"minsize": 8, "mode": "hide"},
        plot_bgcolor="white",
    )
    return fig


def _iso(t: dt.datetime) -> str:
    return t.strftime("%Y-%m-%d %H:%M:%S")
