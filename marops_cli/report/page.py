"""One HTML page (docs/report.md): headings, tables, links and plotly figures, with
plotly.js inlined once, or loaded from the one copy a report of several pages shares,
so the page opens without a network."""

from __future__ import annotations

import html
import re
from collections.abc import Sequence
from typing import Any

from ..config import clipped
from ..errors import InputError
from .basemap import TILE_HOST, tiles_on

EXTRA = "report"
"""The optional dependencies' extra: ``pip install 'marops[report]'``."""


def plain(value: Any) -> str:
    """A value from the folder's files as text on a figure. plotly reads a figure's
    strings (hover texts, legend entries, titles, tick labels) as a little HTML, so an
    order id ``<a href=…>`` would be drawn as a link and ``<b>`` as bold: ``&``, ``<``
    and ``>`` are escaped, which plotly shows as the characters."""
    return html.escape(str(value), quote=False)


def short(value: Any, most: int = 40) -> str:
    """A name from the folder's files cut to ``most`` characters for a legend or an axis
    label, which would otherwise take the figure's width from its plot."""
    return clipped(str(value), most)


def require_plotly() -> None:
    """Stop with one line (exit 2) naming the extra when plotly is not installed, or the
    variable when ``MAROPS_TILES`` says neither on nor off: before any work."""
    try:
        import plotly  # noqa: F401
    except ImportError:
        raise InputError(f"--report needs plotly: pip install 'marops[{EXTRA}]'") from None
    tiles_on()


CONFIG = {
    "displaylogo": False,
    "responsive": True,
    # plotly.js's "Share chart..." button uploads the figure, every order id and stop
    # of it, to Plotly Cloud: the page sends nothing anywhere.
    "showSendToCloud": False,
    "plotlyServerURL": "",
}
"""The figures' plotly config."""


def script_name() -> str:
    """The name of the plotly.js that the pages of a report share (docs/report.md):
    ``plotly-<version>.min.js``, so a page keeps the one it was made with."""
    from plotly.offline import get_plotlyjs_version

    version = re.sub(r"[^0-9A-Za-z.+-]", "_", str(get_plotlyjs_version()))
    return f"plotly-{version}.min.js"


def script_bytes() -> bytes:
    """plotly.js, as the shared file holds it."""
    from plotly.offline import get_plotlyjs

    return get_plotlyjs().encode("utf-8")


def _policy(shared: bool) -> str:
    """What the browser lets the page load: its own inline scripts and styles, the shared
    plotly.js where the page loads it (``shared``) and the map tiles (none with
    ``MAROPS_TILES=off``), nothing else (no fetch, no other image host), whatever a
    figure's text holds."""
    images = "img-src data: blob:" + (f" {TILE_HOST.rstrip('/')}" if tiles_on() else "")
    # The shared plotly.js is a file beside the page (or above it). For a page opened
    # from a file, Chromium matches 'self' to file: URLs; for the folder served over
    # HTTP, 'self' is that server. Narrower sources do not work: a path alone is no
    # valid source ("../plotly.js" is ignored), and a hash source or an integrity
    # attribute needs a CORS response, which a file: URL never is (the script is
    # refused). 'file:' would refuse the script of a folder served over HTTP.
    scripts = "script-src 'self' 'unsafe-inline'" if shared else "script-src 'unsafe-inline'"
    return "; ".join(
        (
            "default-src 'none'",
            scripts,  # plotly.js (inlined or the shared file) and the figures, inlined
            "style-src 'unsafe-inline'",
            images,  # the map tiles
            "base-uri 'none'",
            "form-action 'none'",
        )
    )


_STYLE = """
body { font-family: system-ui, sans-serif; margin: 1.5em; color: #222; max-width: 1400px; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 1.6em; }
h1, h2, p { overflow-wrap: anywhere; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
th { background: #f3f3f3; text-align: left; }
p.note { color: #555; font-size: 0.9em; }
"""


class Page:
    """A report page built top to bottom; :meth:`html` renders it."""

    def __init__(self, title: str) -> None:
        self.title = title
        self._parts: list[str] = [f"<h1>{html.escape(title)}</h1>"]
        self._figures = 0

    def up(self, href: str, text: str) -> None:
        """A link under the title to the page of the run this page is part of."""
        link = f'<a href="{html.escape(href)}">{html.escape(text)}</a>'
        self._parts.insert(1, f'<p class="note">↑ {link}</p>')

    def heading(self, text: str) -> None:
        self._parts.append(f"<h2>{html.escape(text)}</h2>")

    def note(self, text: str) -> None:
        self._parts.append(f'<p class="note">{html.escape(text)}</p>')

    def table(
        self, header: Sequence[str], rows: Sequence[Sequence[Any]], *, links: int | None = None
    ) -> None:
        """A table; cells that are numbers align right. ``links``: the column whose cells
        are ``(text, href)`` pairs."""
        head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
        body = []
        for row in rows:
            cells = []
            for i, cell in enumerate(row):
                if i == links and isinstance(cell, tuple):
                    text, href = cell
                    a = f'<a href="{html.escape(href)}">{html.escape(text)}</a>'
                    cells.append(f"<td>{a}</td>")
                else:
                    num = isinstance(cell, int | float) or _numeric(str(cell))
                    cls = ' class="num"' if num else ""
                    cells.append(f"<td{cls}>{html.escape(str(cell))}</td>")
            body.append("<tr>" + "".join(cells) + "</tr>")
        self._parts.append(f"<table><tr>{head}</tr>{''.join(body)}</table>")

    def figure(self, fig: Any, div_id: str, post_script: str | None = None) -> None:
        """A plotly figure under a fixed element id (the same page for the same data);
        ``post_script``: JavaScript run once it is drawn (``{plot_id}``: its id)."""
        import plotly.io as pio

        self._figures += 1
        self._parts.append(
            pio.to_html(
                fig,
                include_plotlyjs=False,
                full_html=False,
                div_id=div_id,
                config=CONFIG,
                post_script=post_script,
            )
        )

    @property
    def has_figures(self) -> bool:
        return self._figures > 0

    def html(self, script: str | None = None) -> str:
        """The whole page; when it has a figure, plotly.js in the head: loaded from
        ``script`` (the shared file's path relative to the page), else inlined."""
        tag = ""
        if self._figures and script is not None:
            tag = f'<script src="{html.escape(script)}"></script>'
        elif self._figures:
            from plotly.offline import get_plotlyjs

            tag = f'<script type="text/javascript">{get_plotlyjs()}</script>'
        policy = _policy(shared=bool(self._figures) and script is not None)
        return (
            '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
            f'<meta http-equiv="Content-Security-Policy" content="{policy}">\n'
            f"<title>{html.escape(self.title)}</title>\n<style>{_STYLE}</style>\n"
            f"{tag}\n</head>\n<body>\n" + "\n".join(self._parts) + "\n</body>\n</html>\n"
        )


def _numeric(text: str) -> bool:
    try:
        float(text.replace(",", "").replace("%", "").split(" ")[0])
    except ValueError:
        return False
    return True
