"""Figures like the paper's (Figs. tradeoff, drones, depots): one per swept flag.

Each panel draws a metric's mean against the swept value, one line per method,
with a band of ± one standard deviation (the paper's shadow). Flags that were not
swept are held at their base value (the config's, else the first given).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pyarrow as pa

from ..sim.metrics import metric_names
from .settings import SWEEP_FLAGS, Setting
from .tables import depot_loads, setting_label

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def _panel(metric: str, axis: str) -> tuple[str, str]:
    """A panel: a metric column of the spec (sim/metrics.py) and its axis label."""
    return metric_names(metric)[0], axis


_DELAY = _panel("avg_delay_h", "average delivery delay (h)")
_ENERGY = _panel("mean_energy_kj", "mean energy consumption (kJ)")
_COST = _panel("combined_cost", "combined cost")
# Panels of each sweep figure (metric column, axis label); "depot_load" is a heatmap.
PANELS: dict[str, tuple[tuple[str, str], ...]] = {
    "alpha": (_DELAY, _ENERGY, _COST),
    "drones": (
        _DELAY,
        _ENERGY,
        _COST,
        _panel("runtime_s", "running time per day (s)"),
        ("depot_load", "depot load (kg)"),
    ),
    "coverage": (_DELAY, _ENERGY, _COST, _panel("delay_unfairness", "delay unfairness (Gini)")),
}
PANELS["depots_n"] = PANELS["coverage"]


def base_values(settings: Sequence[Setting], base: Setting) -> dict[str, float]:
    """Where each flag is held when another one is plotted."""
    held = {}
    for flag in SWEEP_FLAGS:
        present = [getattr(s, flag) for s in settings]
        value = getattr(base, flag)
        held[flag] = value if value in present else present[0]
    return held


def _slice(summary: pa.Table, flag: str, held: dict[str, float]) -> np.ndarray:
    """Rows of ``summary`` where every flag but ``flag`` is at its held value."""
    keep = np.ones(summary.num_rows, dtype=bool)
    for other, value in held.items():
        if other != flag:
            keep &= np.isclose(summary.column(other).to_numpy().astype(float), value)
    return keep


def sweep_figure(
    summary: pa.Table,
    results: pa.Table,
    flag: str,
    methods: Sequence[str],
    held: dict[str, float],
) -> Figure:
    """Metrics against the swept ``flag``, one line per method."""
    panels = PANELS[flag]
    ncols = min(3, len(panels))
    nrows = -(-len(panels) // ncols)
    # matplotlib loads with the first figure: running jobs (workers.py) never needs it.
    # The object API: no pyplot state, no display needed.
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4.2 * ncols, 3.4 * nrows), dpi=100, layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax in axes[len(panels) :]:
        ax.set_visible(False)
    rows = _slice(summary, flag, held)
    x_all = summary.column(flag).to_numpy().astype(float)
    method = np.asarray(summary.column("method").to_pylist(), dtype=object)
    for ax, (metric, label) in zip(axes, panels, strict=False):
        if metric == "depot_load":
            _depot_panel(fig, ax, results, flag, methods[0], held)
            continue
        for m in methods:
            sel = rows & (method == m)
            order = np.argsort(x_all[sel])
            x = x_all[sel][order]
            mean = summary.column(f"{metric}_mean").to_numpy()[sel][order]
            std = summary.column(f"{metric}_std").to_numpy()[sel][order]
            ax.plot(x, mean, marker="o", label=m)
            ax.fill_between(x, mean - std, mean + std, alpha=0.2)
        ax.set_xlabel(SWEEP_FLAGS[flag][1])
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"{SWEEP_FLAGS[flag][1]} ({_held_text(flag, held)})", fontsize=10)
    return fig


def _held_text(flag: str, held: dict[str, float]) -> str:
    return ", ".join(f"{f} = {v:g}" for f, v in held.items() if f != flag)


def _depot_panel(
    fig: Figure, ax: Axes, results: pa.Table, flag: str, method: str, held: dict[str, float]
) -> None:
    """Heatmap: mean parcel weight picked up at each depot, per swept value."""
    rows = _slice(results, flag, held) & (
        np.asarray(results.column("method").to_pylist(), dtype=object) == method
    )
    where = ""
    hub = results.column("hub").to_numpy() if "hub" in results.column_names else None
    if hub is not None and np.unique(hub[rows]).size > 1:  # hubs' depot ids are their own
        first = int(hub[rows].min())
        rows &= hub == first
        where = f", hub {first}"
    x_all = results.column(flag).to_numpy().astype(float)
    xs = sorted(set(x_all[rows].tolist()))
    loads = [depot_loads(results, rows & np.isclose(x_all, x)) for x in xs]
    width = max(v.size for v in loads)
    grid = np.full((len(xs), width), np.nan)
    for i, v in enumerate(loads):
        grid[i, : v.size] = v
    im = ax.imshow(grid, aspect="auto", cmap="viridis", origin="lower")
    ax.set_yticks(range(len(xs)), [f"{x:g}" for x in xs])
    ax.set_xlabel("depot (service area) id")
    ax.set_ylabel(SWEEP_FLAGS[flag][1])
    ax.set_title(f"depot load (kg/day), {method}{where}", fontsize=9)
    fig.colorbar(im, ax=ax)


def unfairness_figure(summary: pa.Table, methods: Sequence[str]) -> Figure:
    """Delay unfairness (Gini over service areas) per method, one bar for each setting
    of the evaluation (``α=0.3``, ``α=0.8`` side by side, ± one std)."""
    from matplotlib.figure import Figure

    settings = sorted(set(summary.column("setting").to_pylist()))
    fig = Figure(
        figsize=(max(4.0, (0.5 * len(settings) + 0.7) * len(methods) + 2.5), 3.8),
        dpi=100,
        layout="constrained",
    )
    ax = fig.subplots()
    setting = np.asarray(summary.column("setting").to_pylist())
    method = np.asarray(summary.column("method").to_pylist(), dtype=object)
    mean = summary.column("delay_unfairness_mean").to_numpy()
    std = summary.column("delay_unfairness_std").to_numpy()
    width = 0.8 / len(settings)
    x = np.arange(len(methods), dtype=float)
    for k, s in enumerate(settings):
        at = [np.flatnonzero((setting == s) & (method == m)) for m in methods]
        heights = [float(mean[i[0]]) if i.size else np.nan for i in at]
        errs = [float(std[i[0]]) if i.size else np.nan for i in at]
        offset = (k - (len(settings) - 1) / 2) * width
        ax.bar(x + offset, heights, width, yerr=errs, capsize=3, label=setting_label(summary, s))
    ax.set_xticks(x, list(methods))
    ax.tick_params(axis="x", labelrotation=30, labelsize=8)
    ax.set_ylabel("delay unfairness (Gini over areas)")
    ax.set_title("delay unfairness per method and setting", fontsize=9)
    ax.legend(fontsize=8, title="setting", title_fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    return fig


ACTIONS = metric_names("actions_stay", "actions_move", "actions_free")
"""The decision shares the actions figure stacks (docs/outputs.md, "Day metrics")."""


def actions_figure(summary: pa.Table, methods: Sequence[str], held: dict[str, float]) -> Figure:
    """Per method at the base setting: the shares of its decisions to stay, move and
    land freely (stacked bars), and beside them its windows waited for a battery per day
    (under an operating model; else the panel says there were none to wait for)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(2.4 * len(methods) + 3.0, 3.8), dpi=100, layout="constrained")
    shares, waits = fig.subplots(1, 2)
    rows = _slice(summary, "", held)
    method = np.asarray(summary.column("method").to_pylist(), dtype=object)
    pick = [int(np.flatnonzero(rows & (method == m))[0]) for m in methods]
    bottom = np.zeros(len(methods))
    for name, colour in zip(ACTIONS, ("tab:gray", "tab:orange", "tab:blue"), strict=True):
        mean = summary.column(f"{name}_mean").to_numpy()[pick].astype(float)
        shares.bar(list(methods), mean, bottom=bottom, color=colour, label=_kind(name))
        bottom += mean
    shares.set_ylim(0, 1)
    shares.set_ylabel("share of decisions")
    shares.legend(fontsize=8, loc="lower right")
    shares.set_title(_held_text("", held), fontsize=9)
    if "battery_waits_mean" in summary.column_names:
        mean = summary.column("battery_waits_mean").to_numpy()[pick].astype(float)
        std = summary.column("battery_waits_std").to_numpy()[pick].astype(float)
        waits.bar(list(methods), mean, yerr=std, capsize=4, color="tab:red", alpha=0.8)
    else:
        waits.text(0.5, 0.5, "the paper's model:\nno battery waits", ha="center", va="center")
        waits.set_xticks([])
    waits.set_ylabel("windows waited for a battery per day")
    for ax in (shares, waits):
        ax.tick_params(axis="x", labelrotation=30, labelsize=8)
        ax.grid(axis="y", alpha=0.3)
    return fig


def _kind(metric: str) -> str:
    return {"stay": "stay", "move": "move", "free": "free landing"}[metric.split("_")[1]]


def save_png(fig: Figure, path: str | Path) -> None:
    """Write ``fig`` as PNG (the path may be a temporary without the suffix)."""
    fig.savefig(path, format="png")
