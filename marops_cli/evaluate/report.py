"""Table III-style summaries (methods as columns, metrics as rows) and the output files."""

from __future__ import annotations

from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from ..io import file_sha256, output_set, run_meta
from ..io.tables import with_meta, write_csv, write_parquet
from ..sim.metrics import metric_specs
from .frontier import FRONTIER_FILE, frontier_table
from .paired import few_days_warning
from .plots import actions_figure, base_values, save_png, sweep_figure, unfairness_figure
from .runner import Prepared
from .settings import Setting, swept_flags
from .tables import SUMMARY_METRICS

# Rows of the paper's Table III (and a few more): the summary's metrics but the ones it
# keeps for the record only; labels and formats from the spec.
_RECORD_ONLY = ("requests", "battery_frac_max", "solver_fallbacks")
TABLE_ROWS = metric_specs(*(m for m in SUMMARY_METRICS if m not in _RECORD_ONLY))
COMBINED_COST_RULE = (
    "per setting, on the means over days and repeats: "
    "(mean energy / max over methods + mean delay / max over methods) / 2"
)


def setting_title(summary: pa.Table, setting: int) -> str:
    """``α = 0.5, 8 drones, coverage 0.25, 16 areas, 4 actions``."""
    row = _rows_of(summary, setting)[0]
    return (
        f"α = {row['alpha']:g}, {row['drones']} drones, coverage {row['coverage']:g}, "
        f"{row['depots_n']} areas, {row['n_actions']} actions"
    )


def _rows_of(summary: pa.Table, setting: int) -> list[dict[str, Any]]:
    return [r for r in summary.to_pylist() if r["setting"] == setting]


def shown(value: float | None, fmt: str) -> str:
    """``value`` in ``fmt``; ``n/a`` where there is none (None, NaN: a spread over a
    single day, an interval with no shared day, a cell an older file has not)."""
    return fmt.format(value) if value is not None and np.isfinite(value) else "n/a"


def mean_pm_std(row: dict[str, Any], key: str, fmt: str = "{:.2f}") -> str:
    """``"0.88 ± 0.10"`` from a summary row's ``key_mean`` and ``key_std`` (``± n/a``
    where the std is missing: a single day or repeat)."""
    return f"{fmt.format(row[f'{key}_mean'])} ± {shown(row[f'{key}_std'], fmt)}"


def table3(summary: pa.Table, setting: int) -> tuple[list[str], list[tuple[str, list[str]]]]:
    """(methods, [(metric label, ["mean ± std" per method])]) for one setting."""
    rows = _rows_of(summary, setting)
    methods = [r["method"] for r in rows]
    body = [
        (m.label, [mean_pm_std(r, m.name, m.fmt) for r in rows])
        for m in TABLE_ROWS
        if f"{m.name}_mean" in summary.column_names
    ]
    return methods, body


def markdown_table(summary: pa.Table, setting: int) -> str:
    """One setting's Table III as a Markdown table."""
    methods, body = table3(summary, setting)
    lines = ["| metric | " + " | ".join(methods) + " |", "|---" * (len(methods) + 1) + "|"]
    lines += [f"| {label} | " + " | ".join(cells) + " |" for label, cells in body]
    return "\n".join(lines)


def sweep_table(summary: pa.Table, flag: str) -> str:
    """Markdown: one row per value of ``flag``, one column per method.

    Cells: mean energy kJ / average delay h / combined cost.
    """
    rows = summary.to_pylist()
    methods = list(dict.fromkeys(r["method"] for r in rows))
    lines = [f"| {flag} | " + " | ".join(methods) + " |", "|---" * (len(methods) + 1) + "|"]
    for v in sorted({r[flag] for r in rows}):
        at = {r["method"]: r for r in rows if r[flag] == v}
        cells = [
            f"{at[m]['mean_energy_kj_mean']:.0f} / {at[m]['avg_delay_h_mean']:.2f} / "
            f"{at[m]['combined_cost_mean']:.2f}"
            for m in methods
        ]
        lines.append(f"| {v:g} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def summary_markdown(summary: pa.Table, prep: Prepared, front: pa.Table | None = None) -> str:
    """``summary.md``: one Table III per setting, with what was run, and the frontier
    over α (``front``) when there is one."""
    days = f"{prep.days[0].isoformat()}..{prep.days[-1].isoformat()}"
    parts = [
        "# marops evaluate",
        "",
        f"{len(prep.days)} days ({days}), {prep.repeats} repeat(s) each; mean ± std "
        "over days and repeats. Combined cost: " + COMBINED_COST_RULE + ".",
    ]
    if (few := few_days_warning(summary)) is not None:  # as evaluate warns on the terminal
        parts += ["", f"**{few[0].upper()}{few[1:]}.**"]
    for s in sorted(set(summary.column("setting").to_pylist())):
        parts += ["", f"## {setting_title(summary, s)}", "", markdown_table(summary, s)]
    if front is not None:
        parts += ["", "## Frontier over α", "", frontier_markdown(front)]
    return "\n".join(parts) + "\n"


def frontier_markdown(front: pa.Table) -> str:
    """The frontier as a Markdown table: one row per method and α (docs/outputs.md)."""
    lines = [
        "Each method's operating point at each α, pooled over the days: a point is "
        "dominated when another (any method, any α, the same fleet and areas) delivers "
        "at least as many parcels at no more delay and energy.",
        "",
        "| drones | areas | method | α | delivered | delivered share | delay h "
        "| energy MJ | kJ per parcel | dominated by |",
        "|---" * 10 + "|",
    ]
    for r in front.to_pylist():
        lines.append(
            f"| {r['drones']} | {r['depots_n']} | {r['method']} | {r['alpha']:g} "
            f"| {r['delivered']:.1f} | {r['delivered_share']:.3f} | {r['avg_delay_h']:.3f} "
            f"| {r['energy_kj'] / 1e3:.2f} | {r['energy_per_parcel_kj']:.1f} "
            f"| {r['dominated_by'] or '—'} |"
        )
    return "\n".join(lines)


TABLES = ("results.parquet", "summary.csv", "summary.md")
"""The tables every evaluation writes into its folder."""
UNFAIRNESS, ACTIONS = "unfairness.png", "actions.png"
"""The figures every evaluation draws, beside one ``<flag>.png`` per swept flag."""


def figures(summary: pa.Table, results: pa.Table, prep: Prepared) -> dict[str, Any]:
    """File name -> figure: one per swept flag, the delay-unfairness bars and the
    methods' decisions and battery waits."""
    cfg = prep.cfg
    base = Setting(cfg.plan.alpha, cfg.sim.drones, cfg.plan.coverage, cfg.segment.n_depots)
    held = base_values(prep.settings, base)
    figs = {
        f"{flag}.png": sweep_figure(summary, results, flag, prep.methods, held)
        for flag in swept_flags(prep.settings)
    }
    figs[UNFAIRNESS] = unfairness_figure(summary, prep.methods)
    figs[ACTIONS] = actions_figure(summary, prep.methods, held)
    return figs


def evaluation_meta(prep: Prepared) -> dict[str, Any]:
    """The ``marops`` metadata of an evaluation's files (docs/outputs.md)."""
    # No run time: the same jobs give the same file wherever and whenever they ran.
    return run_meta(
        command="evaluate",
        stamp=False,
        config=prep.cfg,
        source=prep.source.source,
        policy=next(iter(prep.actor_files.values()), None),
        method=",".join(prep.methods),
        seed=prep.cfg.sim.seed,
        extra={
            "methods": prep.methods,
            "days": [d.isoformat() for d in prep.days],
            "repeats": prep.repeats,
            "settings": [s.columns() for s in prep.settings],
            "swept": swept_flags(prep.settings),
            "combined_cost": COMBINED_COST_RULE,
            "actors": {
                m: {"name": p.name, "sha256": file_sha256(p)} for m, p in prep.actor_files.items()
            },
        },
    )


def write_outputs(
    out: Path, prep: Prepared, results: pa.Table, summary: pa.Table, *, plots: bool = True
) -> list[Path]:
    """``results.parquet``, ``summary.csv``, ``summary.md`` and the PNGs, all or none."""
    meta = evaluation_meta(prep)
    paths = [out / name for name in TABLES]
    figs = figures(summary, results, prep) if plots else {}
    front = frontier_table(results)
    with output_set() as files:
        files.write_with(paths[0], lambda p: write_parquet(with_meta(results, meta), p))
        files.write_with(paths[1], lambda p: write_csv(_csv_summary(summary), p))
        files.write_bytes(paths[2], summary_markdown(summary, prep, front).encode("utf-8"))
        if front is not None:
            files.write_with(out / FRONTIER_FILE, lambda p: write_csv(front, p))
            paths.append(out / FRONTIER_FILE)
        for name, fig in figs.items():
            files.write_with(out / name, partial(_save_to, fig))
            paths.append(out / name)
    return paths


def _csv_summary(summary: pa.Table) -> pa.Table:
    """``summary`` as ``summary.csv`` holds it: a ``_std`` cell of a single day or repeat
    (``n`` = 1, no spread) empty rather than ``nan``, which reads as a failed metric."""
    import pyarrow.compute as pc

    single = pc.equal(summary.column("n"), 1)
    for k, name in enumerate(summary.column_names):
        if name.endswith("_std"):
            column = summary.column(k)
            empty = pa.nulls(len(column), column.type)
            summary = summary.set_column(k, name, pc.if_else(single, empty, column))
    return summary


def _save_to(fig: Any, path: Path) -> None:
    save_png(fig, path)
