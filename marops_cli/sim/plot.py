"""Figures of a replayed day: a small-multiples map like the paper's trajectory figure,
and its operations over the day."""

from __future__ import annotations

import datetime as dt
import math
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure  # the object API: no pyplot state, no backend chosen

from ..data.table import DayRequests
from ..plans.ranges import delays_h
from ..segment.plot import draw_areas
from .ops import BUSY, WAITING
from .replay import FlownDay

# The delay scale: green (on time) to red (late); depots and drones keep clear of it.
DELAY_CMAP = "RdYlGn_r"
# tab10 without its green and red, which the delay scale holds.
DRONE_COLOURS = (
    "tab:blue",
    "tab:orange",
    "tab:purple",
    "tab:brown",
    "tab:pink",
    "tab:gray",
    "tab:olive",
    "tab:cyan",
)


def plot_day(res: FlownDay, reqs: DayRequests, path: str | Path) -> None:
    """Write :func:`day_figure` as a PNG."""
    fig = day_figure(res, reqs)
    fig.savefig(path, format="png")


def day_figure(res: FlownDay, reqs: DayRequests) -> Figure:
    """One panel per window (its clock times in the title): areas, depots, pending
    requests coloured by delay, each drone's routes in its colour; km axes, a legend of
    the drones and a delay scale."""
    st = res.state
    n = len(res.plans)
    cols = math.ceil(math.sqrt(n))
    rows = math.ceil(n / cols)
    fig = Figure(figsize=(3.2 * cols + 1.0, 3.2 * rows + 0.8), dpi=90, constrained_layout=True)
    axes = fig.subplots(rows, cols, squeeze=False, sharex=True, sharey=True)
    vmax = max(1.0, float(reqs.n_windows * reqs.window_hours) / 2)
    span = dt.timedelta(hours=reqs.window_hours)
    sc = None
    for ax, plan in zip(axes.ravel(), res.plans, strict=False):
        t = plan.t
        # Requests pending at the start of window t: visible, not delivered before t.
        pend = (reqs.visible_w <= t) & ((st.delivered_w < 0) | (st.delivered_w >= t))
        d = delays_h(reqs.due_w[pend], t, reqs.window_hours)
        draw_areas(ax, st.depots, labels=False)
        sc = ax.scatter(
            reqs.x_m[pend] / 1000,
            reqs.y_m[pend] / 1000,
            c=d,
            s=5,
            cmap=DELAY_CMAP,
            vmin=0,
            vmax=vmax,
            zorder=3,
        )
        for r in plan.routes:
            pts = (
                np.vstack(
                    [
                        st.depots.xy[r.start],
                        np.column_stack([reqs.x_m, reqs.y_m])[list(r.stops)].reshape(-1, 2),
                        st.depots.xy[r.end],
                    ]
                )
                / 1000
            )
            if len(pts) > 2 or r.start != r.end:
                ax.plot(
                    pts[:, 0],
                    pts[:, 1],
                    "-",
                    color=DRONE_COLOURS[r.drone % len(DRONE_COLOURS)],
                    lw=1.2,
                    zorder=5,
                )
        served = sum(len(r.stops) for r in plan.routes)
        start = reqs.window_start(t)
        ax.set_title(
            f"window {t}, {start:%H:%M}–{start + span:%H:%M}\n"
            f"{int(pend.sum())} pending, {served} served",
            fontsize=8,
        )
        ax.set_xlabel("")
        ax.set_ylabel("")
        ax.tick_params(labelsize=6)
    for ax in axes[-1]:  # the axes are shared: units once, under the last row
        ax.set_xlabel("x (km east of centre)", fontsize=7)
    for ax in axes[:, 0]:
        ax.set_ylabel("y (km north of centre)", fontsize=7)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    if sc is not None:
        fig.colorbar(
            sc, ax=axes.ravel().tolist(), shrink=0.6, label="delay of a pending request (h)"
        )
    fig.legend(
        handles=_legend(res.n_drones),
        loc="outside lower center",
        ncols=min(len(DRONE_COLOURS), res.n_drones) + 1,
        fontsize=7,
        frameon=False,
    )
    fig.suptitle(
        f"{reqs.day.isoformat()} — {res.method}, {res.n_drones} drones (local times)", fontsize=11
    )
    return fig


def _legend(n_drones: int) -> list[Any]:
    """Handles of the legend: a depot, and each drone colour with the drones it draws
    (colours repeat past eight drones: ``drones 0, 8``)."""
    from matplotlib.lines import Line2D

    handles: list[Any] = [
        Line2D([], [], ls="", marker="s", color="black", mec="white", ms=6, label="depot")
    ]
    n = len(DRONE_COLOURS)
    for k in range(min(n, n_drones)):
        ids = [str(d) for d in range(k, n_drones, n)]
        label = ("drones " if len(ids) > 1 else "drone ") + ", ".join(ids)
        handles.append(Line2D([], [], color=DRONE_COLOURS[k], lw=1.5, label=label))
    return handles


def plot_operations(res: FlownDay, reqs: DayRequests, path: str | Path) -> None:
    """The day's operations (docs/outputs.md): parcels waiting per depot at the start of
    each window (a heatmap), and over the day the spare charged batteries (all depots)
    and the drones waiting for one; the battery line only under an operating model that
    limits batteries."""
    st = res.state
    waiting = st.waiting_w
    n_w, n_dep = waiting.shape
    ops = st.ops
    fig = Figure(
        figsize=(max(6.0, 0.35 * n_w + 2.5), 3.0 + 0.18 * n_dep + 2.6),
        dpi=90,
        constrained_layout=True,
    )
    top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=[max(2.0, 0.18 * n_dep + 1.0), 2.0])
    im = top.imshow(
        waiting.T,
        aspect="auto",
        origin="lower",
        cmap="viridis",
        interpolation="nearest",
        extent=(-0.5, n_w - 0.5, -0.5, n_dep - 0.5),
    )
    fig.colorbar(im, ax=top, label="parcels waiting")
    top.set_ylabel("depot")
    top.set_title("parcels waiting per depot at the start of each window", fontsize=9)
    windows = np.arange(n_w)
    if ops is not None and ops.limited:
        bottom.plot(windows, ops.charged_w.sum(axis=1), "-o", ms=3, label="spare charged batteries")
    if ops is not None:
        waits = (ops.held_w == WAITING).sum(axis=1)
        bottom.bar(windows, waits, color="tab:red", alpha=0.6, label="drones waiting for a battery")
        busy = (ops.held_w == BUSY).sum(axis=1)
        bottom.plot(windows, busy, "--", color="tab:gray", label="drones on long flights")
        bottom.legend(fontsize=7, loc="best")
    else:
        bottom.text(
            0.5,
            0.5,
            "the paper's model: a charged battery every window",
            ha="center",
            va="center",
            transform=bottom.transAxes,
        )
    bottom.set_ylabel("batteries, drones (count)")
    bottom.grid(alpha=0.3)
    step = max(1, n_w // 12)
    ticks = windows[::step]
    bottom.set_xticks(ticks)
    bottom.set_xticklabels([reqs.window_start(int(w)).strftime("%H:%M") for w in ticks], fontsize=7)
    bottom.set_xlabel("window start (local time)")
    fig.suptitle(
        f"{reqs.day.isoformat()} — {res.method}, {res.n_drones} drones: operations", fontsize=11
    )
    fig.savefig(path, format="png")
