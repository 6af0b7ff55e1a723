"""The report of a several-day or city run: every day's metrics, the totals, the city's
coverage, a chart over the days, and a link to each day's own report."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any
from urllib.parse import quote

from ..config import count
from .folder import REPORT, route_files_exist
from .page import Page, plain

_COLUMNS = (
    ("delivered", "{}"),
    ("undelivered", "{}"),
    ("delivered_share", "{:.3f}"),
    ("mean_energy_kj", "{:.1f}"),
    ("avg_delay_h", "{:.3f}"),
    ("objective_j_mj", "{:.2f}"),
    ("objective_g_mj", "{:.2f}"),
)


def _link(folder: Path, row: dict[str, Any]) -> tuple[str, str] | str:
    """The day's own report below ``folder``, as (text, relative link), when there. The
    link is percent-encoded: a folder named ``javascript:…`` is a path, never a script."""
    day, hub = str(row["day"]), row.get("hub", 0)
    for rel in (f"hub-{hub}/{day}", f"hub-{hub}", day):
        if (folder / rel / REPORT).is_file() or (folder / rel / "metrics.json").is_file():
            # The name's bytes, as the file system holds them (any, on Linux).
            return ("report", quote(os.fsencode(f"{rel}/{REPORT}")))
    return ""


def index_page(folder: Path, doc: dict[str, Any]) -> Page:
    """The page of ``folder``'s top-level ``metrics.json`` (``days``, ``total``, ``city``)."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    days = doc.get("days", [])
    # A city's days are hub-days, a city of one hub (hub 0) too.
    hubs = "city" in doc or any(d.get("hub", 0) for d in days)
    page = Page(f"marops: {count(len(days), 'hub-day' if hubs else 'day')} — {folder.name}")
    city = doc.get("city")
    if city:  # a city's page opens on its map and its hubs
        from .citymap import city_section

        city_section(page, folder, doc)
    page.heading("Days")
    header = ["hub"] * hubs + ["day", "method", *(c for c, _ in _COLUMNS), "report"]
    rows = []
    for d in days:
        cells = [d.get("hub", 0)] * hubs + [str(d["day"]), d["method"]]
        cells += [f.format(d[c]) if d.get(c) is not None else "" for c, f in _COLUMNS]
        rows.append([*cells, _link(folder, d)])
    page.table(header, rows, links=len(header) - 1)
    # A city's hubs have pages of their own (their days and totals): linked here too.
    pages = [(h, folder / f"hub-{h}") for h in sorted({d.get("hub", 0) for d in days})]
    pages = [(h, p) for h, p in pages if hubs and not city and (p / "metrics.json").is_file()]
    pages = [(h, p) for h, p in pages if not route_files_exist(p)]  # one day: linked above
    if pages:
        page.heading("Hubs")
        page.table(
            ("hub", "report"),
            [(h, ("report", quote(f"{p.name}/{REPORT}"))) for h, p in pages],
            links=1,
        )
    total = doc.get("total")
    if total:
        page.heading("Totals over the days")
        page.table(("quantity", "value"), [(k, _fmt(v)) for k, v in total.items()])
    if city:  # its figures; those by day and by hub are the tables' and the map's
        page.heading("The city's coverage")
        scalars = [(k, _fmt(v)) for k, v in city.items() if not isinstance(v, list | dict)]
        page.table(("quantity", "value"), scalars)
    if days:
        labels = [plain(f"hub {d.get('hub', 0)} {d['day']}" if hubs else d["day"]) for d in days]
        fig = make_subplots(
            rows=1,
            cols=3,
            subplot_titles=("delivered share", "mean energy per drone (kJ)", "average delay (h)"),
        )
        for i, key in enumerate(("delivered_share", "mean_energy_kj", "avg_delay_h"), start=1):
            fig.add_trace(
                go.Bar(x=labels, y=[d.get(key) for d in days], name=key, showlegend=False),
                row=1,
                col=i,
            )
        fig.update_layout(height=360, margin={"l": 50, "r": 20, "t": 40, "b": 80})
        page.heading("Over the days")
        page.figure(fig, "days")
    return page


def _fmt(v: Any) -> Any:
    return f"{v:.4g}" if isinstance(v, float) else v
