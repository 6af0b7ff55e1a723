"""``marops segment``: depots, service areas and action candidates."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..errors import InputError
from ..io.atomic import allow_replacing_foreign
from . import options as o
from .common import (
    PLAIN,
    STATE,
    console,
    emit_json,
    guarded,
    info,
    make_config,
    parse_center,
    print_drop_report,
    refuse_overwriting_inputs,
    require_input,
    set_output,
    show_table,
    table,
)
from .common import table as table_


@guarded
def segment(
    data: o.Data,
    out: Annotated[Path, typer.Option("--out", help="Where to write depots.json.")],
    n_depots: Annotated[
        int | None, typer.Option("--n-depots", help="Number of depots / service areas [16].")
    ] = None,
    method: Annotated[
        str | None,
        typer.Option(
            "--method", help="kmeans (k-means areas, docs/method.md §2) or squares [kmeans]."
        ),
    ] = None,
    size_km: Annotated[
        float | None, typer.Option("--size-km", help="Side of the study-area square in km [10].")
    ] = None,
    center: Annotated[
        str | None,
        typer.Option("--center", help="Study-area centre LNG,LAT [the densest square]."),
    ] = None,
    dates: Annotated[
        str | None,
        typer.Option("--dates", help="History days, e.g. 0801..0824 or 801,802 [all days]."),
    ] = None,
    actions: Annotated[
        int | None,
        typer.Option("--actions", help="Action candidates per depot, itself included [4]."),
    ] = None,
    seed: Annotated[int | None, typer.Option("--seed", help="k-means random seed [0].")] = None,
    year: o.Year = None,
    strict: o.Strict = False,
    geojson: Annotated[
        bool,
        typer.Option("--geojson", help="Also write depots and areas as GeoJSON beside --out."),
    ] = False,
    plot: Annotated[
        bool,
        typer.Option("--plot", help="Also draw a PNG map of customers and areas beside --out."),
    ] = False,
    hubs: Annotated[
        str | None,
        typer.Option(
            "--hubs",
            help="Tile the city into hubs instead (docs/method.md §1.1): a number, or auto "
            "(while the next hub holds at least 1 % of the orders); --out names the hubs "
            "file (hubs.json) that replay-day --hubs runs.",
        ),
    ] = None,
    force: o.Force = False,
    config: o.Config = None,
    quiet: o.Quiet = False,
    as_json: o.Json = False,
) -> None:
    """Cluster a LaDe export into depots and service areas (k-means or squares), or tile
    a city into hubs (--hubs)."""
    set_output(quiet, as_json)
    allow_replacing_foreign(force)
    from ..data.dates import parse_days
    from ..io import output_set, run_meta
    from ..segment import areas_geojson
    from ..segment.plot import plot_depots
    from ..segment.run import segment_file

    require_input(data)
    if hubs is not None:
        _segment_hubs(data, out, hubs, size_km, dates, year, strict, config)
        return
    if out.suffix != ".json":
        raise InputError(f"--out names the depots file, e.g. depots.json; got {out.name}")
    gj_path, png_path = out.with_suffix(".geojson"), out.with_suffix(".png")
    refuse_overwriting_inputs([out, gj_path, png_path], data=data, config=config)
    cfg = make_config(
        config,
        data__year=year,
        data__size_km=size_km,
        data__center=parse_center(center),
        data__strict=strict or None,
        segment__n_depots=n_depots,
        segment__method=method,
        segment__n_actions=actions,
        segment__seed=seed,
    )
    day_list = parse_days(dates, cfg.data.year) if dates else None
    if PLAIN or STATE["quiet"] or STATE["json"]:
        res = segment_file(data, cfg, day_list)
    else:
        with console.status("segmenting…"):
            res = segment_file(data, cfg, day_list)
    print_drop_report(res.table.report, data.name)
    meta = run_meta(
        command="segment",
        config=cfg,
        source=res.table.source,
        method=cfg.segment.method,
        seed=cfg.segment.seed,
        extra={
            "days": [d.isoformat() for d in res.days],
            "n_history": int(res.history_xy.shape[0]),
            "rows": res.table.report.to_dict(),
        },
    )
    with output_set() as files:
        files.write_json(out, res.depots.to_dict(meta))
        if geojson:
            files.write_json(gj_path, areas_geojson(res.depots, meta))
        if plot:
            title = (
                f"{cfg.segment.method}: {len(res.depots)} depots, "
                f"{res.history_xy.shape[0]:,} history requests, {len(res.days)} days"
            )
            files.write_with(png_path, lambda p: plot_depots(res.depots, res.history_xy, p, title))
    _print_summary(res)
    written = [out, *(p for p, want in ((gj_path, geojson), (png_path, plot)) if want)]
    info("wrote " + ", ".join(str(p) for p in written))
    if STATE["json"]:
        emit_json(
            {
                "command": "segment",
                "files": [str(p) for p in written],
                "method": cfg.segment.method,
                "frame": {
                    "center_lng": res.depots.frame.center_lng,
                    "center_lat": res.depots.frame.center_lat,
                    "size_km": res.depots.frame.size_km,
                },
                "history_days": [d.isoformat() for d in res.days],
                "depots": len(res.depots),
            }
        )


def _print_summary(res) -> None:  # type: ignore[no-untyped-def]
    f = res.depots.frame
    t = table(
        f"{len(res.depots)} depots around ({f.center_lng:.5f}, {f.center_lat:.5f}), "
        f"{f.size_km:g} km square"
    )
    for col in ("depot", "x km", "y km", "history", "candidates"):
        t.add_column(col, justify="right" if col != "candidates" else "left")
    for i in range(len(res.depots)):
        x, y = res.depots.xy[i] / 1000.0
        cands = " ".join(str(c) for c in res.depots.candidates[i])
        t.add_row(str(i), f"{x:.2f}", f"{y:.2f}", f"{res.depots.n_history[i]:,}", cands)
    show_table(t)


def _hub_count(text: str) -> int | None:
    if text.strip().lower() == "auto":
        return None
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise InputError(f"--hubs expects a number of hubs (1 or more) or auto, got {text!r}")
    return n


def _segment_hubs(  # type: ignore[no-untyped-def]
    data: Path, out: Path, hubs: str, size_km, dates, year, strict, config
) -> None:
    """``segment --hubs``: hub squares over the city, densest first, into a hubs file."""
    from ..data.dates import parse_days
    from ..data.reader import read_lade
    from ..io import output_set, run_meta
    from ..segment.hubs import find_hubs, hubs_doc

    n_hubs = _hub_count(hubs)
    if out.suffix != ".json":
        raise InputError(f"--out names the hubs file, e.g. hubs.json; got {out.name}")
    refuse_overwriting_inputs([out], data=data, config=config)
    cfg = make_config(config, data__year=year, data__size_km=size_km, data__strict=strict or None)
    if cfg.data.center is not None:
        raise InputError("--hubs places the study areas itself: drop [data] center")
    day_list = parse_days(dates, cfg.data.year) if dates else None
    table = read_lade(data, cfg.data)
    found, total = find_hubs(table, cfg.data, day_list, n_hubs)
    print_drop_report(table.report, data.name)
    days = day_list or table.days()
    meta = run_meta(
        command="segment",
        config=cfg,
        source=table.source,
        extra={"days": [d.isoformat() for d in days], "hubs": hubs},
    )
    with output_set() as files:
        files.write_json(out, hubs_doc(found, total, meta))
    held = sum(h.orders for h in found)
    t = table_(
        f"{len(found)} hubs of {cfg.data.size_km:g} km, holding {held:,} of {total:,} orders "
        f"({100 * held / max(total, 1):.1f} %)"
    )
    for col in ("hub", "centre lng", "centre lat", "orders", "share %"):
        t.add_column(col, justify="right")
    for h in found:
        t.add_row(
            str(h.id),
            f"{h.frame.center_lng:.5f}",
            f"{h.frame.center_lat:.5f}",
            f"{h.orders:,}",
            f"{100 * h.orders / max(total, 1):.1f}",
        )
    show_table(t)
    info(f"wrote {out}")
    if STATE["json"]:
        emit_json(
            {
                "command": "segment",
                "files": [str(out)],
                "hubs": len(found),
                "orders": total,
                "covered_share": held / total if total else 0.0,
            }
        )
