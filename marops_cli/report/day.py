"""A day's (or one window's) report page: the map, the drones' timeline, the day's
metrics and the orders it left out (docs/report.md)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from ..config import count
from ..data.frame import Frame
from ..errors import InputError
from .basemap import tiles_on
from .checks import reading
from .daymap import TILE_CREDIT_SCRIPT, WINDOW_SLIDER_SCRIPT, flown, map_figure
from .folder import RouteFiles
from .page import Page
from .timeline import timeline_figure

if TYPE_CHECKING:
    from ..segment.depots import Depots

# Rows of the metrics table (docs/outputs.md, "Day metrics"), in this order.
METRICS = (
    "delivered_share",
    "mean_energy_kj",
    "energy_kj",
    "avg_delay_h",
    "delay_unfairness",
    "avg_early_h",
    "objective_j_mj",
    "objective_g_mj",
    "co2_g",
    "battery_frac_mean",
    "battery_frac_max",
    "actions_stay",
    "actions_move",
    "actions_free",
    "waiting_max",
    "drones",
    "runtime_s",
)
# What the day left out, and why (docs/outputs.md, "Day metrics").
LEFT_OUT = (
    ("orders_due", "orders of the file due that day"),
    ("outside_area", "left out: outside the study square"),
    ("outside_hours", "left out: due outside service hours"),
    ("requests", "planned (requests)"),
    ("unservable_heavy", "of those, heavier than every drone can lift"),
    ("unservable_far", "of those, out of every drone's reach"),
    ("delivered", "delivered"),
    ("undelivered", "not delivered by the end of the day"),
)


def depot_points(files: RouteFiles, depots: Depots | None) -> dict[int, tuple[float, float]]:
    """Every depot's (lng, lat): of the depots given, else those the routes use. Depots
    given must hold every depot the routes take off from or land at, where they have it
    (within a metre): else they are another run's depots of the same square."""
    if depots is None:
        return {s["depot"]: (s["lng"], s["lat"]) for s in files.stops if s["depot"] is not None}
    lng, lat = depots.lnglat()
    points = {i: (float(lng[i]), float(lat[i])) for i in range(len(depots))}
    for s in files.stops:
        d = s["depot"]
        if d is None or s.get("kind") not in ("start", "end"):
            continue
        if d not in points:
            raise InputError(
                f"the depots file has {len(depots)} depots and the run's routes fly from depot "
                f"{d}: give the run's depots file",
                column="depot",  # app.report names the depots file
            )
        if _metres_apart(points[d], (float(s["lng"]), float(s["lat"]))) > 1.0:
            raise InputError(
                f"the depots file puts depot {d} elsewhere than the run's routes do: give the "
                "run's depots file",
                column="depot",
            )
    return points


def _metres_apart(a: tuple[float, float], b: tuple[float, float]) -> float:
    """Distance of two (lng, lat) points a few kilometres apart at most, in metres."""
    k = 111_320.0  # metres per degree of latitude
    dx = (a[0] - b[0]) * k * math.cos(math.radians((a[1] + b[1]) / 2.0))
    return math.hypot(dx, (a[1] - b[1]) * k)


def area_rings(depots: Depots | None) -> list[tuple[int, list[float], list[float]]]:
    """Each service area's outline (depot, longitudes, latitudes)."""
    if depots is None:
        return []
    from ..segment import areas_geojson

    rings = []
    for f in areas_geojson(depots, {})["features"]:
        if f["properties"]["kind"] == "service_area":
            ring = f["geometry"]["coordinates"][0]
            rings.append((f["properties"]["depot"], [p[0] for p in ring], [p[1] for p in ring]))
    return rings


def _frame(meta: dict[str, Any], depots: Depots | None) -> Frame | None:
    """The study square: the run's (its files' metadata), which the depots must share."""
    f = meta.get("frame")
    run = Frame(f["center_lng"], f["center_lat"], f["size_km"]) if f else None
    if depots is None:
        return run
    if run is not None and not _same(run, depots.frame):
        raise InputError(
            f"the depots file is of another study square ({_square(depots.frame)}) than the "
            f"run's ({_square(run)}): give the run's depots file",
            column="frame",  # app.report names the depots file
        )
    return depots.frame


def _square(f: Frame) -> str:
    return f"centre {f.center_lng:.5f}, {f.center_lat:.5f}, {f.size_km:g} km"


def _same(a: Frame, b: Frame) -> bool:
    pairs = zip(a.to_dict().values(), b.to_dict().values(), strict=True)
    return all(abs(x - y) < 1e-6 for x, y in pairs)


def day_page(files: RouteFiles, metrics_doc: dict[str, Any] | None, depots: Depots | None) -> Page:
    """The report of a replayed day (with its ``metrics.json``) or of one planned window."""
    meta = files.meta
    day = metrics_doc["days"][0] if metrics_doc and metrics_doc.get("days") else None
    page = Page(_title(files, day))
    page.heading("Map")
    n = sum(flown(r) for r in files.routes)
    page.note(
        f"{count(n, 'route')} flown, one line each in its drone's colour; hover a stop for its "
        "arrival time, weight and delay; the slider shows one window; click a drone in "
        "the legend to hide it. "
        + (
            "Map tiles appear when the browser is online; offline, the service areas are the map."
            if tiles_on()
            else "The service areas are the map (MAROPS_TILES=off: no tiles fetched)."
        )
        + ("" if depots is not None else " Depots: those the routes use (no depots file given).")
    )
    frame = _frame(meta, depots)  # the square first: depots of another square say so
    points = depot_points(files, depots)
    with reading(*files.paths):
        fig = map_figure(files, points, area_rings(depots), frame)
        scripts = [TILE_CREDIT_SCRIPT] if fig.layout.images else []
        scripts += [WINDOW_SLIDER_SCRIPT] if fig.layout.sliders else []
        page.figure(fig, "map", "".join(scripts) or None)
        page.heading("Drones over the day")
        page.note(
            "Each bar a flight from take-off to landing (→ the depot it lands at); grey: "
            "a window the drone waits at its depot."
        )
        page.figure(timeline_figure(files), "timeline")
    routes = files.paths[-1:]  # none where the rows were not read from a folder
    if day is not None:
        with reading(*(p.with_name("metrics.json") for p in routes)):
            _metrics(page, day)
    elif meta.get("objective") or meta.get("solver"):
        with reading(*routes):  # the window's plan: the routes' metadata
            _window(page, meta)
    return page


def _title(files: RouteFiles, day: dict[str, Any] | None) -> str:
    meta = files.meta
    drones = len({r["drone"] for r in files.routes})
    when = meta.get("day") or (str(files.routes[0]["day"]) if files.routes else "")
    method = meta.get("method", "")
    hub = files.routes[0]["hub"] if files.routes else 0
    where = f"hub {hub}, " if hub else ""
    fleet = count(drones, "drone")
    if day is None and "window" in meta:
        return f"marops: {where}{when} window {meta['window']} — {method}, {fleet}"
    return f"marops: {where}{when} — {method}, {fleet}"


def _metrics(page: Page, day: dict[str, Any]) -> None:
    from ..sim.metrics import METRICS as BY_NAME

    page.heading("The day's metrics (docs/method.md §8)")
    rows = []
    for name in METRICS:
        if name not in day or day[name] is None:
            continue
        spec = BY_NAME.get(name)
        label = spec.label.replace(" per day", "") if spec else name
        value = spec.day_fmt.format(day[name]) if spec else f"{day[name]:.3f}"
        rows.append((label, value, spec.unit if spec else ""))
    page.table(("metric", "value", "unit"), rows)
    page.heading("Orders left out")
    page.table(
        ("orders", "count"),
        [(text, day[k]) for k, text in LEFT_OUT if day.get(k) is not None],
    )


# The window's objective (the route files' ``objective``, in joules, docs/outputs.md) as
# plan-window prints it: energies in MJ (kJ for the routes' energy), the gap in %.
_OBJECTIVE = {
    "J": ("window objective J", "mj"),
    "G": ("its controllable part G", "mj"),
    "energy_j": ("energy of the routes", "kj"),
    "served": ("requests served", ""),
    "pending": ("requests pending", ""),
    "bound_G": ("bound on G", "mj"),
    "gap": ("gap to the bound", "%"),
}


def _window(page: Page, meta: dict[str, Any]) -> None:
    page.heading("The window's plan (docs/method.md §4.2)")
    rows: list[tuple[str, Any]] = []
    solver = meta.get("solver") or {}
    for k, v in solver.items():
        if v is not None:  # the selection's objective: joules, as J
            rows.append((f"solver {k}", _unit(v, "mj") if k == "objective" else _fmt(v)))
    for k, v in (meta.get("objective") or {}).items():
        label, unit = _OBJECTIVE.get(k, (k, ""))
        rows.append((label, _unit(v, unit)))
    page.table(("quantity", "value"), rows)


def _unit(v: Any, unit: str) -> Any:
    """A value of the window's plan in the unit plan-window prints it in: joules as MJ
    (``mj``) or kJ (``kj``), a share as a percentage (``%``); other values as
    :func:`_fmt` gives them."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        return _fmt(v)
    if unit == "mj":
        return f"{v / 1e6:,.3f} MJ"
    if unit == "kj":
        return f"{v / 1e3:,.1f} kJ"
    if unit == "%":
        return f"{100 * v:.2f} %"
    return _fmt(v)


def _fmt(v: Any) -> Any:
    """A float to six significant digits (the solver's objective has sixteen)."""
    return f"{v:.6g}" if isinstance(v, float) else v
