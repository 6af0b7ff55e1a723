"""``marops segment``: depots, service areas and action candidates."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from . import options as o
from .common import (
    STATE,
    begin,
    emit_json,
    guarded,
    info,
    protect_inputs,
    show_table,
    table,
    warn,
)
from .progress import Terminal

if TYPE_CHECKING:
    from ..segment.depots import Depots


@guarded
@o.takes_options("segment")
def segment_command(
    data: o.Data,
    out: Annotated[Path, typer.Option("--out", help="Where to write depots.json.")],
    n_depots: o.NDepots = None,
    segmentation: o.Segmentation = None,
    size_km: o.SizeKm = None,
    center: o.Center = None,
    dates: Annotated[
        str | None,
        typer.Option(
            "--dates", help="History days, e.g. 0801..0824 or 801,802 [default: all days]."
        ),
    ] = None,
    actions: o.Actions = None,
    seed: o.SegmentSeed = None,
    year: o.Year = None,
    strict: o.Strict = False,
    geojson: Annotated[
        bool,
        typer.Option(
            "--geojson",
            help="Also write depots and areas as GeoJSON beside --out (--hubs: always, "
            "the hubs' squares and depots).",
        ),
    ] = False,
    plot: Annotated[
        bool,
        typer.Option(
            "--plot",
            help="Also draw a PNG map of customers and areas (--hubs: the hubs' squares "
            "and depots) beside --out.",
        ),
    ] = False,
    hubs: Annotated[
        str | None,
        typer.Option(
            "--hubs",
            help="Tile the city into hubs instead (docs/method.md §1.1): a number, or auto "
            "(while the next hub holds at least 1 % of the orders); --out names the hubs "
            "file (hubs.json) that replay-day --hubs runs, with hubs.geojson beside it.",
        ),
    ] = None,
    force: o.Force = False,
    config: o.Config = None,
    quiet: o.Quiet = False,
    as_json: o.Json = False,
    method: Annotated[
        str | None, typer.Option("--method", hidden=True, help="Former name of --segmentation.")
    ] = None,
    *,
    options: dict[str, Any],
) -> None:
    """Cluster a LaDe export into depots and service areas (k-means or squares), or tile
    a city into hubs (--hubs)."""
    data = begin(data, quiet=quiet, as_json=as_json, force=force)
    options = _former_method(method, options)
    from ..app.options import hubs_options, planner_config
    from ..app.segment import check_json_out, refuse_with_hubs
    from ..app.segment import segment as segment_data

    if hubs is not None:
        read, refused = hubs_options(options)
        refuse_with_hubs(hubs, refused)
        _segment_hubs(data, out, hubs, dates, config, plot, read)
        return
    check_json_out(out, "depots")
    gj_path, png_path = out.with_suffix(".geojson"), out.with_suffix(".png")
    protect_inputs([out, *[gj_path] * geojson, *[png_path] * plot], [data, config])
    cfg = planner_config(config, **options)
    res = segment_data(
        data, cfg, days=dates, out=out, geojson=geojson, plot=plot, progress=Terminal()
    )
    _print_summary(res.depots)
    info("wrote " + ", ".join(str(p) for p in res.files))
    if STATE["json"]:
        emit_json(_json_doc(res, cfg))


def _former_method(method: str | None, options: dict[str, Any]) -> dict[str, Any]:
    """``--method``, segment's former name of ``--segmentation`` (hidden; a run method is
    what ``--method`` names everywhere else): taken, with a note, unless both are given."""
    if method is None:
        return options
    if options.get("segmentation") is not None:
        from ..errors import InputError

        raise InputError("give --segmentation alone (--method is its former name)")
    warn("--method is now --segmentation for segment; --method will go")
    return {**options, "segmentation": method}


def _json_doc(res: Any, cfg: Any) -> dict[str, Any]:
    """``--json``: the files written, the segmentation, the frame, the days and depots."""
    frame = res.depots.frame
    return {
        "command": "segment",
        "files": [str(p) for p in res.files],
        "method": cfg.segment.method,
        "frame": {
            "center_lng": frame.center_lng,
            "center_lat": frame.center_lat,
            "size_km": frame.size_km,
        },
        "history_days": [d.isoformat() for d in res.days],
        "depots": len(res.depots),
    }


def _print_summary(depots: Depots) -> None:
    from ..config import count

    f = depots.frame
    t = table(
        f"{count(len(depots), 'depot')} around ({f.center_lng:.5f}, "
        f"{f.center_lat:.5f}), "
        f"{f.size_km:g} km square"
    )
    for col in ("depot", "x km", "y km", "history", "candidates"):
        t.add_column(col, justify="right" if col != "candidates" else "left")
    for i in range(len(depots)):
        x, y = depots.xy[i] / 1000.0
        cands = " ".join(str(c) for c in depots.candidates[i])
        t.add_row(str(i), f"{x:.2f}", f"{y:.2f}", f"{depots.n_history[i]:,}", cands)
    show_table(t)


def _segment_hubs(
    data: Path,
    out: Path,
    hubs: str,
    dates: str | None,
    config: Path | None,
    plot: bool,
    options: dict[str, Any],
) -> None:
    """``segment --hubs``: hub squares over the city, densest first, into a hubs file
    (with its GeoJSON and, with ``plot``, its map)."""
    from ..app.options import planner_config
    from ..app.segment import check_json_out, hub_count, segment_hubs

    hub_count(hubs)  # a bad --hubs is the first error
    check_json_out(out, "hubs")
    gj_path, png_path = out.with_suffix(".geojson"), out.with_suffix(".png")
    protect_inputs([out, gj_path, *[png_path] * plot], [data, config])
    cfg = planner_config(config, **options)
    res = segment_hubs(data, cfg, hubs, days=dates, out=out, plot=plot, progress=Terminal())
    asked = hub_count(hubs)
    if asked is not None and len(res.hubs) < asked:
        warn(
            f"--hubs {asked}: the orders fill only {len(res.hubs)} non-overlapping "
            f"{cfg.data.size_km:g} km square{'s' * (len(res.hubs) != 1)}"
        )
    _print_hubs(res, cfg.data.size_km)


def _print_hubs(res: Any, size_km: float) -> None:
    """The hubs placed (their centres, orders and share of all orders), the files
    written, and with ``--json`` the summary."""
    from ..config import count

    held, total = sum(h.orders for h in res.hubs), res.total
    t = table(
        f"{count(len(res.hubs), 'hub')} of {size_km:g} km, "
        f"holding {held:,} of {total:,} orders ({100 * held / max(total, 1):.1f} %)"
    )
    for col in ("hub", "centre lng", "centre lat", "orders", "share %"):
        t.add_column(col, justify="right")
    for h in res.hubs:
        t.add_row(
            str(h.id),
            f"{h.frame.center_lng:.5f}",
            f"{h.frame.center_lat:.5f}",
            f"{h.orders:,}",
            f"{100 * h.orders / max(total, 1):.1f}",
        )
    show_table(t)
    info("wrote " + ", ".join(str(p) for p in res.files))
    if STATE["json"]:
        emit_json(
            {
                "command": "segment",
                "files": [str(p) for p in res.files],
                "hubs": len(res.hubs),
                "orders": total,
                "covered_share": held / total if total else 0.0,
            }
        )
