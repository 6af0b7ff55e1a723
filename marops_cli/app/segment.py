"""Place the study area and segment it into depots and service areas (``segment``,
docs/method.md §2), or tile a city into hubs (``segment --hubs``, §1.1)."""

from __future__ import annotations

import datetime as dt
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..config import PlannerConfig, ascii_number, clipped, count
from ..errors import InputError, option
from ..io import output_set, run_meta
from ..io.atomic import check_unheld
from ..io.ownership import register_inputs
from .inputs import Data, data_name, read_data
from .messages import drop_report
from .progress import SILENT, Progress

if TYPE_CHECKING:
    from ..data.table import LadeTable
    from ..segment.depots import Depots
    from ..segment.hubs import Hub


@dataclass(frozen=True)
class Segmentation:
    """Depots and service areas, the history they were made from, and the files written."""

    depots: Depots
    days: list[dt.date]
    history_xy: np.ndarray
    """(n, 2) customer points used, metres."""
    table: LadeTable
    meta: dict[str, Any]
    files: list[Path]

    def doc(self) -> dict[str, Any]:
        """The depots file's document (``depots.json``, docs/outputs.md)."""
        return self.depots.to_dict(self.meta)


@dataclass(frozen=True)
class HubTiling:
    """Hub squares over a city, densest first, and the files written."""

    hubs: list[Hub]
    total: int
    """Orders the hubs were placed from."""
    table: LadeTable
    meta: dict[str, Any]
    files: list[Path]

    def doc(self) -> dict[str, Any]:
        """The hubs file's document (``hubs.json``, docs/outputs.md)."""
        from ..segment.hubs import hubs_doc

        return hubs_doc(self.hubs, self.total, self.meta)


def check_json_out(out: str | Path, what: str) -> None:
    """``--out`` names the ``what`` file (``depots.json``): a ``.json`` name, not a folder
    (``--out .``) nor a file of another kind."""
    out = Path(out)
    if out.suffix == ".json" and not out.is_dir():
        return
    this = f"a {out.suffix} file" if out.suffix else "a name without .json"
    if out.is_dir():
        this = "a folder"
    raise InputError(
        f"{option('out')} names the {what} file, e.g. {what}.json; this is {this}", file=out
    )


def history_days(days: str | list[dt.date] | None, year: int) -> list[dt.date] | None:
    """``days`` as dates (``"0801..0810"``, ``"801,802"`` or dates); None for all."""
    from ..data.dates import parse_days

    if isinstance(days, str):  # "" (an unset shell variable) is refused, never "all"
        return parse_days(days, year, option("dates"))
    return list(days) if days else None


def segment(
    data: Data,
    cfg: PlannerConfig,
    *,
    days: str | list[dt.date] | None = None,
    out: str | Path | None = None,
    geojson: bool = False,
    plot: bool = False,
    progress: Progress = SILENT,
) -> Segmentation:
    """Depots for the requests of ``days`` (all days when None); with ``out`` (the
    depots file) write it, and beside it the areas as GeoJSON and a PNG map when asked."""
    from ..segment import areas_geojson
    from ..segment.run import segment_table

    register_inputs([data])  # never an output
    if out is not None:
        check_json_out(out, "depots")
        check_unheld(out)  # not into a folder another run holds
    day_list = history_days(days, cfg.data.year)
    progress.start("segmenting…", 0, "")  # no steps to count: a spinner on a terminal
    try:
        res = segment_table(read_data(data, cfg.data), cfg, day_list)
    finally:
        progress.finish()
    drop_report(progress, res.table, data_name(data))
    _far_depots(progress, res.depots, res.history_xy)
    # No time stamp: the runs that read a depots file record its SHA-256 and keep their
    # days only while it matches, so segmenting again the same way gives the same bytes.
    meta = run_meta(
        command="segment",
        config=cfg,
        source=res.table.source,
        method=cfg.segment.method,
        seed=cfg.segment.seed,
        stamp=False,
        extra={
            "days": [d.isoformat() for d in res.days],
            "n_history": int(res.history_xy.shape[0]),
            "rows": res.table.report.to_dict(),
        },
    )
    done = Segmentation(res.depots, res.days, res.history_xy, res.table, meta, [])
    if out is None:
        return done
    path = Path(out)
    gj_path, png_path = path.with_suffix(".geojson"), path.with_suffix(".png")
    with output_set() as files:
        files.write_json(path, done.doc(), journal=True)  # analysts edit it
        if geojson:
            files.write_json(gj_path, areas_geojson(res.depots, meta))
        if plot:  # matplotlib loads only to draw (its first import writes its font cache)
            from ..segment.plot import plot_depots

            title = (
                f"{cfg.segment.method}: {len(res.depots)} depots, "
                f"{res.history_xy.shape[0]:,} history requests, {len(res.days)} days"
            )
            files.write_with(png_path, lambda p: plot_depots(res.depots, res.history_xy, p, title))
    done.files.extend([path, *(p for p, want in ((gj_path, geojson), (png_path, plot)) if want)])
    return done


FAR_DEPOT_M = 2000.0
"""How far from every history request a depot may lie before ``segment`` warns: a
k-means centroid between clusters (across a river, between two towns) serves none. Well above
what a sparse single day of history leaves between a centroid and its nearest request
(under 0.8 km over the example's and the synthetic cities' days)."""


def _far_depots(progress: Progress, depots: Depots, history_xy: np.ndarray) -> None:
    """Warn of the k-means depots no history request lies near, naming the options that
    place depots where the requests are."""
    from ..segment.depots import nearest_depot

    if depots.method != "kmeans" or not history_xy.size:
        return  # squares' depots sit on a grid whatever the requests
    _, dist = nearest_depot(depots.xy, history_xy)
    far = np.flatnonzero(dist > FAR_DEPOT_M)
    if far.size:
        worst = int(far[np.argmax(dist[far])])
        ids = ", ".join(str(int(i)) for i in far[:8]) + (", …" if far.size > 8 else "")
        progress.warning(
            f"depot{'s' * (far.size > 1)} {ids} lie{'s' * (far.size == 1)} more than "
            f"{FAR_DEPOT_M / 1000:g} km from every history request (depot {worst}: "
            f"{dist[worst] / 1000:,.1f} km), between clusters of requests; more --n-depots, "
            "a smaller --size-km or --center places depots where the requests are"
        )


def hub_count(text: str | int) -> int | None:
    """``--hubs``: a number of hubs (1 to ``MAX_HUBS``, in ASCII digits), or None for
    ``auto``."""
    from ..segment.hubs import MAX_HUBS

    if isinstance(text, str) and text.strip().lower() == "auto":
        return None
    try:
        n = ascii_number(text, int) if isinstance(text, str) else int(text)
    except ValueError:
        n = 0
    if not 1 <= n <= MAX_HUBS:
        raise InputError(
            f"{option('hubs')} expects a number of hubs (1 to {MAX_HUBS}) or auto, "
            f"got {clipped(repr(text))}"
        )
    return n


def refuse_with_hubs(hubs: str | int, given: Mapping[str, object]) -> None:
    """``hubs`` places the study areas and segments each hub's depots as ``replay-day``
    does, by the ``[segment]`` settings: an option of one study area's depots, which it
    would ignore, is refused naming it (after a bad ``hubs``, the first error).
    ``given``: option name (``n_depots``) -> its value, None or False when not given."""
    hub_count(hubs)
    moot = [option(k) for k, v in given.items() if v is not None and v is not False]
    if moot:
        raise InputError(
            f"{option('hubs')} places the study areas itself and writes the hubs file: "
            f"drop {', '.join(moot)} (each hub's depots are segmented when replay-day "
            "--hubs runs it, by the [segment] settings of --config)"
        )


def segment_hubs(
    data: Data,
    cfg: PlannerConfig,
    hubs: str | int,
    *,
    days: str | list[dt.date] | None = None,
    out: str | Path | None = None,
    plot: bool = False,
    progress: Progress = SILENT,
) -> HubTiling:
    """Hub squares over the city's orders due on ``days`` (all when None), densest
    first: ``hubs`` of them, or ``auto`` (while the next holds at least 1 % of the
    orders); with ``out`` write the hubs file that ``replay-day --hubs`` runs, beside it
    the hubs GeoJSON (each hub's square and depots) and, with ``plot``, a PNG map."""
    from ..segment.hubs import find_hubs

    register_inputs([data])  # never an output

    n_hubs = hub_count(hubs)
    if out is not None:
        check_json_out(out, "hubs")
        check_unheld(out)  # not into a folder another run holds
    if cfg.data.center is not None:
        raise InputError(f"{option('hubs')} places the study areas itself: drop [data] center")
    day_list = history_days(days, cfg.data.year)
    table = read_data(data, cfg.data)
    found, total = find_hubs(table, cfg.data, day_list, n_hubs)
    drop_report(progress, table, data_name(data))
    used = day_list or table.days()
    meta = run_meta(  # no time stamp, as a depots file's
        command="segment",
        config=cfg,
        source=table.source,
        extra={"days": [d.isoformat() for d in used], "hubs": str(hubs)},
        stamp=False,
    )
    done = HubTiling(found, total, table, meta, [])
    if out is not None:
        _write_hubs(done, Path(out), used, cfg, plot, progress)
    return done


def _write_hubs(
    done: HubTiling,
    path: Path,
    days: list[dt.date],
    cfg: PlannerConfig,
    plot: bool,
    progress: Progress,
) -> None:
    """The hubs file, the hubs GeoJSON beside it (each hub's square, and its depots as
    replay-day segments them over ``days``) and, with ``plot``, its PNG map."""
    from ..segment.hubmap import hub_depots, hubs_geojson

    depots, why = hub_depots(done.table, cfg, done.hubs, days)
    for hub, reason in why.items():
        progress.warning(f"hub {hub}: no depots drawn ({reason})")
    gj_path, png_path = path.with_suffix(".geojson"), path.with_suffix(".png")
    with output_set() as files:
        files.write_json(path, done.doc(), journal=True)  # analysts edit it
        files.write_json(gj_path, hubs_geojson(done.hubs, done.total, depots, done.meta))
        if plot:  # matplotlib loads only to draw
            from ..segment.plot import plot_hubs

            t = done.table
            on = np.isin(t.delivery_day, np.array(days, dtype="datetime64[D]"))
            n = sum(len(d) for d in depots.values())
            title = (
                f"{count(len(done.hubs), 'hub')} of {cfg.data.size_km:g} km, {count(n, 'depot')}, "
                f"{done.total:,} orders, {len(days)} days"
            )
            files.write_with(
                png_path,
                lambda p: plot_hubs(done.hubs, depots, t.lng[on], t.lat[on], p, title),
            )
    done.files.extend([path, gj_path, *[png_path] * plot])
