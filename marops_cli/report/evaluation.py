"""An evaluation's report page (``marops evaluate --out DIR``): the comparison tables,
the paired differences with their bootstrap intervals, and the sweeps, interactive."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..config import count
from .checks import Col, check_meta, check_table, meta_error, reading
from .folder import read_input, rows_at_most, table_meta
from .page import Page, plain, short

_INT, _NUMBER, _TEXT = Col("int"), Col("number"), Col("text")
_SETTING = {
    "setting": _INT,
    "alpha": _NUMBER,
    "drones": _INT,
    "coverage": _NUMBER,
    "depots_n": _INT,
    "n_actions": _INT,
}
"""A setting's columns in the summary (its title, the sweeps' axes)."""
_RESULTS = {
    "setting": _INT,
    "method": _TEXT,
    "day": Col("date"),
    "objective_j_mj": _NUMBER,
    "delivered_share": _NUMBER,
}
"""The columns of ``results.parquet`` the chart of every day draws."""
_PAIRED = {
    "setting": _INT,
    "method": _TEXT,
    "metric": _TEXT,
    "days": _INT,
    # no interval where no day is shared (a CSV's nan reads as an empty cell)
    **dict.fromkeys(("mean_diff", "ci_low", "ci_high"), Col("number", empty=True, finite=False)),
    "days_better": _INT,
    "lower_is_better": Col("bool"),
}
_FRONTIER = {
    "method": _TEXT,
    **dict.fromkeys(("alpha", "delivered", "avg_delay_h", "energy_kj"), _NUMBER),
    "dominated": Col("bool"),
}
"""The frontier's columns its figure draws (a frontier.csv without them has none)."""
_OPTIONAL = {
    "calendar_days": _INT,
    "hub": _INT,
    "repeat": _INT,
    "against": _TEXT,
    "few_days": Col("bool"),
    "drones": _INT,
    "depots_n": _INT,
    # none per parcel where a point delivers none
    "energy_per_parcel_kj": Col("number", empty=True, finite=False),
    "delivered_share": _NUMBER,
    "dominated_by": Col("text", empty=True),
}
"""Columns the page reads where a table has them (an older marops wrote fewer)."""
_META: dict[str, type | tuple[type, ...]] = {
    "days": list,
    "methods": list,
    "repeats": int,
    "swept": list,
    "settings": list,
    "config": dict,
}
"""The keys of ``results.parquet``'s marops metadata the page reads."""


def _columns(table: Any, columns: dict[str, Col]) -> dict[str, Col]:
    """``columns``, with the :data:`_OPTIONAL` ones that ``table`` has."""
    extra = {c: col for c, col in _OPTIONAL.items() if c in table.column_names}
    return {**extra, **columns}


def _summary_columns(summary: Any) -> dict[str, Col]:
    """The summary's columns the page reads: a setting's, the method's, and the mean and
    spread of each metric of its tables that it has (a spread is empty over one day)."""
    from ..evaluate.report import TABLE_ROWS

    columns = {**_SETTING, "method": _TEXT}
    for m in TABLE_ROWS:
        if f"{m.name}_mean" in summary.column_names:
            columns[f"{m.name}_mean"] = _NUMBER
            columns[f"{m.name}_std"] = Col("number", empty=True, finite=False)
    return columns


def _check_meta(meta: dict[str, Any], path: Path) -> None:
    """``results.parquet``'s metadata as marops writes it: the days and methods as
    text, each flag swept one of the sweep's and each setting its flags' numbers."""
    from ..evaluate.settings import SWEEP_FLAGS

    check_meta(meta, path, _META)
    for key in ("days", "methods", "swept"):
        for value in meta.get(key) or []:
            if not isinstance(value, str) or (key == "swept" and value not in SWEEP_FLAGS):
                what = f"flags among {', '.join(SWEEP_FLAGS)}" if key == "swept" else "text"
                raise meta_error(path, key, f"a list of {what}", meta[key])
    for s in meta.get("settings") or []:
        if not isinstance(s, dict) or not all(
            isinstance(s.get(f), int | float) and not isinstance(s.get(f), bool)
            for f in SWEEP_FLAGS
        ):
            raise meta_error(path, "settings", "a list of settings", meta["settings"])
    for section in (meta.get("config") or {}).values():
        if not isinstance(section, dict):
            raise meta_error(path, "config", "an object of sections", meta["config"])


def _tables(folder: Path) -> tuple[Any, Any, Any | None, dict[str, Any]]:
    """(summary, results, paired or None, the results' metadata) of ``folder``, each
    column the page reads checked as marops writes it."""
    from ..data.arrow import read_csv_file
    from ..evaluate.settings import MAX_REPLAYS

    summary = read_input(folder / "summary.csv", read_csv_file)
    _check(summary, folder / "summary.csv", _summary_columns(summary), "an evaluation's summary")
    results_path = folder / "results.parquet"
    results = read_input(results_path, rows_at_most(MAX_REPLAYS, "replays an evaluation runs"))
    _check(results, results_path, _RESULTS, "an evaluation's results")
    meta = table_meta(results, results_path)
    _check_meta(meta, results_path)
    paired_path = folder / "paired.csv"
    paired = read_input(paired_path, read_csv_file) if paired_path.is_file() else None
    if paired is not None and paired.num_rows:
        _check(paired, paired_path, _PAIRED, "a paired comparison")
    return summary, results, paired, meta


def _check(table: Any, path: Path, columns: dict[str, Col], what: str) -> None:
    """:func:`~.checks.check_table` of ``columns`` and the :data:`_OPTIONAL` ones
    ``table`` has."""
    check_table(table, path, _columns(table, columns), what, redo="evaluate again")


def evaluation_page(folder: Path) -> Page:
    """The report of an evaluation folder."""
    from ..evaluate.report import COMBINED_COST_RULE, setting_title, table3

    summary, results, paired, meta = _tables(folder)
    days = meta.get("days", [])
    page = Page(f"marops evaluate: {', '.join(meta.get('methods', []))} — {folder.name}")
    page.note(
        f"{count(len(days), 'day')} ({', '.join(days)}), "
        f"{count(meta.get('repeats', 1), 'repeat')}; "
        f"mean ± std over days and repeats. Combined cost: {COMBINED_COST_RULE}."
    )
    if "calendar_days" in summary.column_names:  # none in an older summary.csv
        from ..evaluate.paired import few_days_warning

        if (few := few_days_warning(summary)) is not None:  # as summary.md says
            page.note(f"{few[0].upper()}{few[1:]}.")
    front = folder / "frontier.csv"
    if front.is_file():  # first: an analyst picks an operating point by looking
        from ..data.arrow import read_csv_file

        table = read_input(front, read_csv_file)
        if _FRONTIER.keys() <= set(table.column_names):  # else of an older marops: none
            _check(table, front, _FRONTIER, "a frontier")
        with reading(front):
            _frontier(page, table.to_pylist())
    with reading(folder / "summary.csv"):
        settings = sorted(set(summary.column("setting").to_pylist()))
        titles = {s: setting_title(summary, s) for s in settings}
        for s in settings:
            methods, body = table3(summary, s)
            page.heading(f"Setting {s}: {titles[s]}")
            page.table(("metric", *methods), [(label, *cells) for label, cells in body])
    if paired is not None and paired.num_rows:
        with reading(folder / "paired.csv"):
            _paired(page, paired, titles)
    with reading(folder / "summary.csv"):
        for flag in meta.get("swept", []):
            _sweep(page, summary, flag, meta)
    with reading(folder / "results.parquet"):
        _per_day(page, results, titles)
    return page


def _paired(page: Page, paired: Any, titles: dict[int, str]) -> None:
    """Each method's mean per-day difference to the reference, with its 95 % interval."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    from ..evaluate.paired import MIN_DAYS, verdict
    from ..evaluate.report import shown

    rows = [_nan_for_empty(r, ("mean_diff", "ci_low", "ci_high")) for r in paired.to_pylist()]
    against = rows[0].get("against", "the reference")
    page.heading(f"Paired against {against}: per-day difference, bootstrap 95 % CI")
    if any(r.get("few_days") for r in rows):  # as evaluate warns on the terminal
        page.note(
            f"Fewer than {MIN_DAYS} days back these differences: the intervals are wide "
            "and no verdict is established."
        )
    page.table(
        ("setting", "method", "metric", "days", "mean diff", "95 % CI", "days better", "verdict"),
        [
            (
                titles.get(r["setting"], r["setting"]),
                r["method"],
                r["metric"],
                r["days"],
                shown(r["mean_diff"], "{:+.4g}"),
                f"[{shown(r['ci_low'], '{:+.4g}')}, {shown(r['ci_high'], '{:+.4g}')}]",
                f"{r['days_better']}/{r['days']}",
                verdict(r),
            )
            for r in rows
        ],
    )
    metrics = list(dict.fromkeys(r["metric"] for r in rows))
    per = {m: [r for r in rows if r["metric"] == m] for m in metrics}
    # Every interval's row labelled (plotly thins a category axis's labels to about one
    # in three where rows are many): a height per row, a tick per row.
    heights = [_ROW_PX * len(per[m]) + _PANEL_PX for m in metrics]
    fig = make_subplots(
        rows=len(metrics),
        cols=1,
        subplot_titles=[_paired_title(m, per[m][0]) for m in metrics],
        row_heights=heights,
        vertical_spacing=_PANEL_GAP_PX / sum(heights),
    )
    for i, metric in enumerate(metrics, start=1):
        sel = per[metric]
        labels = [
            plain(f"{short(r['method'])} · {titles.get(r['setting'], r['setting'])}") for r in sel
        ]
        fig.add_trace(
            go.Scatter(
                x=[r["mean_diff"] for r in sel],
                y=labels,
                mode="markers",
                marker={"size": 9},
                error_x={
                    "type": "data",
                    "symmetric": False,
                    "array": [r["ci_high"] - r["mean_diff"] for r in sel],
                    "arrayminus": [r["mean_diff"] - r["ci_low"] for r in sel],
                },
                name=plain(metric),
                showlegend=False,
            ),
            row=i,
            col=1,
        )
        fig.add_vline(x=0.0, line={"color": "#888", "dash": "dot"}, row=i, col=1)
        fig.update_yaxes(
            type="category",
            tickmode="array",
            tickvals=labels,
            ticktext=labels,
            autorange="reversed",  # the table's order, top down
            row=i,
            col=1,
        )
    fig.update_layout(
        height=sum(heights) + _PANEL_GAP_PX * (len(metrics) - 1) + 60,
        margin={"l": 320, "r": 20, "t": 40},
    )
    page.figure(fig, "paired")


_ROW_PX = 24
"""Height of a paired interval's row (its label's line)."""
_PANEL_PX = 70
"""Height of a paired panel besides its rows: its axis and title."""
_PANEL_GAP_PX = 50


def _paired_title(metric: str, row: dict[str, Any]) -> str:
    """A paired panel's title: the metric's label (the summary tables' wording) and
    which way is better, as paired.csv's ``lower_is_better`` says."""
    from ..sim.metrics import METRICS

    spec = METRICS.get(metric)
    label = spec.label if spec is not None else metric
    lower = row.get("lower_is_better")
    if isinstance(lower, str):  # a CSV's text
        lower = lower.strip().lower() == "true"
    if lower is None and spec is not None:
        lower = spec.lower_is_better
    better = "" if lower is None else f": {'lower' if lower else 'higher'} is better"
    return plain(f"{label}, method − {row.get('against', 'reference')}{better}")


def _frontier(page: Page, rows: list[dict[str, Any]]) -> None:
    """Each method's operating points over α: delay against energy per day, and
    delivered against energy, one line per method (and fleet), a point per α; a
    dominated point is drawn open and says by which point (docs/outputs.md, "Frontier")."""
    import plotly.graph_objects as go
    from plotly.colors import qualitative
    from plotly.subplots import make_subplots

    from ..evaluate.report import shown

    if not rows or not _FRONTIER.keys() <= set(rows[0]):
        return
    groups = list(dict.fromkeys((r.get("drones"), r.get("depots_n")) for r in rows))
    fig = make_subplots(
        rows=1,
        cols=2,
        subplot_titles=[
            "average delay (h) against energy: lower left is better",
            "delivered per day against energy: upper left is better",
        ],
    )
    lines = list(dict.fromkeys((r["method"], r.get("drones"), r.get("depots_n")) for r in rows))
    for k, (method, drones, areas) in enumerate(lines):
        mine = sorted(
            (
                r
                for r in rows
                if (r["method"], r.get("drones"), r.get("depots_n")) == (method, drones, areas)
            ),
            key=lambda r: r["alpha"],
        )
        colour = qualitative.Plotly[k % len(qualitative.Plotly)]
        name = (
            short(method)
            if len(groups) == 1
            else f"{short(method)} · {drones} drones, {areas} areas"
        )
        hover = ["<br>".join(plain(line) for line in _frontier_hover(r)) for r in mine]
        symbols = ["circle-open" if r["dominated"] else "circle" for r in mine]
        for col, y in ((1, "avg_delay_h"), (2, "delivered")):
            fig.add_trace(
                go.Scatter(
                    x=[r["energy_kj"] / 1e3 for r in mine],
                    y=[r[y] for r in mine],
                    mode="lines+markers+text",
                    text=[f"{r['alpha']:g}" for r in mine],
                    textposition="top center",
                    hovertext=hover,
                    hoverinfo="text",
                    line={"color": colour},
                    marker={"color": colour, "size": 11, "symbol": symbols},
                    name=plain(name),
                    legendgroup=plain(name),
                    showlegend=col == 1,
                ),
                row=1,
                col=col,
            )
    fig.update_xaxes(title_text="energy per day (MJ)")
    fig.update_yaxes(title_text="average delay (h)", row=1, col=1)
    fig.update_yaxes(title_text="delivered per day", row=1, col=2)
    fig.update_layout(height=440, margin={"l": 60, "r": 20, "t": 50, "b": 50})
    page.heading("Frontier over α: each method's operating points")
    page.note(
        "A point per α (its label), pooled over the days. An open point is dominated: "
        "another point (any method, any α) delivers at least as many parcels with no more "
        "delay and no more energy. Pick an operating point among the filled ones."
    )
    page.figure(fig, "frontier")
    page.table(
        ("method", "α", "delivered", "delay h", "energy MJ", "kJ per parcel", "dominated by"),
        [
            (
                r["method"] if len(groups) == 1 else f"{r['method']} · {r.get('drones')} drones",
                f"{r['alpha']:g}",
                f"{r['delivered']:.1f}",
                f"{r['avg_delay_h']:.3f}",
                f"{r['energy_kj'] / 1e3:.2f}",
                shown(r.get("energy_per_parcel_kj"), "{:.1f}"),
                r.get("dominated_by") or "—",
            )
            for r in rows
        ],
    )


def _nan_for_empty(row: dict[str, Any], keys: tuple[str, ...]) -> dict[str, Any]:
    """``row`` with NaN for the empty cells of ``keys``: the NaN marops wrote (an interval
    over no shared day), which a CSV reads back as an empty cell."""
    return {**row, **{k: float("nan") for k in keys if k in row and row[k] is None}}


def _frontier_hover(r: dict[str, Any]) -> list[str]:
    """A frontier point's hover lines (each escaped by the caller)."""
    from ..evaluate.report import shown

    lines = [
        f"{short(r['method'])} α={r['alpha']:g}",
        f"delivered {r['delivered']:.1f} per day ({shown(r.get('delivered_share'), '{:.3f}')})",
        f"delay {r['avg_delay_h']:.3f} h",
        f"energy {r['energy_kj'] / 1e3:.2f} MJ per day "
        f"({shown(r.get('energy_per_parcel_kj'), '{:.1f}')} kJ per parcel)",
    ]
    if r["dominated"]:
        lines.append(f"dominated by {short(r.get('dominated_by') or '')}")
    return lines


def _sweep(page: Page, summary: Any, flag: str, meta: dict[str, Any]) -> None:
    """The metrics against a swept flag, one line per method (± one std), the other
    flags at their base values."""
    import plotly.graph_objects as go
    from plotly.colors import qualitative
    from plotly.subplots import make_subplots

    from ..evaluate.plots import PANELS
    from ..evaluate.settings import SWEEP_FLAGS

    panels = [(m, label) for m, label in PANELS[flag] if m in _means(summary)]
    rows = [r for r in summary.to_pylist() if _held(r, flag, meta)]
    methods = list(dict.fromkeys(r["method"] for r in rows))
    fig = make_subplots(rows=1, cols=len(panels), subplot_titles=[p[1] for p in panels])
    for k, m in enumerate(methods):
        mine = sorted((r for r in rows if r["method"] == m), key=lambda r: r[flag])
        # A method's colour in every panel, as its one legend entry shows it.
        colour = qualitative.Plotly[k % len(qualitative.Plotly)]
        for i, (metric, _) in enumerate(panels, start=1):
            fig.add_trace(
                go.Scatter(
                    x=[r[flag] for r in mine],
                    y=[r[f"{metric}_mean"] for r in mine],
                    error_y={"type": "data", "array": [r[f"{metric}_std"] or 0 for r in mine]},
                    mode="lines+markers",
                    line={"color": colour},
                    marker={"color": colour},
                    name=plain(short(m)),
                    legendgroup=plain(m),
                    showlegend=i == 1,
                ),
                row=1,
                col=i,
            )
            fig.update_xaxes(title_text=SWEEP_FLAGS[flag][1], row=1, col=i)
    fig.update_layout(height=380, margin={"l": 50, "r": 20, "t": 50, "b": 50})
    page.heading(f"Sweep over {SWEEP_FLAGS[flag][1]}")
    page.figure(fig, f"sweep-{flag}")


def _means(summary: Any) -> set[str]:
    return {c[: -len("_mean")] for c in summary.column_names if c.endswith("_mean")}


def _held(row: dict[str, Any], flag: str, meta: dict[str, Any]) -> bool:
    """The row's other flags sit at their base values: the config's where it was run,
    else the first value given (as the PNG figures hold them)."""
    from ..evaluate.settings import SWEEP_FLAGS

    settings = meta.get("settings", [])
    cfg = meta.get("config", {})
    for other, (field, _) in SWEEP_FLAGS.items():
        if other == flag or not settings:
            continue
        section, key = field.split("__")
        present = [s[other] for s in settings]
        base = cfg.get(section, {}).get(key)
        held = base if base in present else present[0]
        if abs(float(row[other]) - float(held)) > 1e-9:
            return False
    return True


def _per_day(page: Page, results: Any, titles: dict[int, str]) -> None:
    """Every replayed day's objective J per method and setting."""
    import plotly.graph_objects as go

    cols = ("setting", "method", "day", "repeat", "hub", "objective_j_mj", "delivered_share")
    rows = results.select([c for c in cols if c in results.column_names]).to_pylist()
    # A city's hubs and the repeats put several points on a day: the hover says which.
    which = [c for c in ("hub", "repeat") if any(r.get(c) for r in rows)]

    def hover(r: dict[str, Any]) -> str:
        said = [f"{c} {plain(r[c])}" for c in which]
        return ", ".join([*said, f"delivered share {r['delivered_share']:.3f}"])

    fig = go.Figure()
    for key in dict.fromkeys((r["setting"], r["method"]) for r in rows):
        mine = [r for r in rows if (r["setting"], r["method"]) == key]
        fig.add_trace(
            go.Scatter(
                x=[plain(r["day"]) for r in mine],
                y=[r["objective_j_mj"] for r in mine],
                mode="markers",
                marker={"size": 9},
                text=[hover(r) for r in mine],
                name=plain(f"{short(key[1])} · {titles.get(key[0], key[0])}"),
            )
        )
    fig.update_layout(
        height=380,
        xaxis={"title": "day", "type": "category"},
        yaxis={"title": "day objective J (MJ)"},
        margin={"l": 60, "r": 20, "t": 30, "b": 50},
    )
    page.heading("Every replayed day: the day objective J")
    page.figure(fig, "days")
