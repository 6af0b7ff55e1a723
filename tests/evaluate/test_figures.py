"""The evaluation's figures and labels show every setting, named by its values."""

from __future__ import annotations

import numpy as np
import pyarrow as pa

from marops_cli.evaluate.plots import unfairness_figure
from marops_cli.evaluate.tables import setting_label


def _summary(alphas: list[float], drones: list[int], methods: list[str]) -> pa.Table:
    rows = []
    for s, (a, d) in enumerate(zip(alphas, drones, strict=True)):
        for k, m in enumerate(methods):
            rows.append(
                {
                    "setting": s,
                    "alpha": a,
                    "drones": d,
                    "coverage": 0.25,
                    "depots_n": 16,
                    "method": m,
                    "delay_unfairness_mean": 0.1 * (s + 1) + 0.01 * k,
                    "delay_unfairness_std": np.nan,
                }
            )
    return pa.Table.from_pylist(rows)


def test_settings_are_labelled_by_what_sets_them_apart() -> None:
    sweep = _summary([0.3, 0.8], [8, 8], ["greedy"])
    assert [setting_label(sweep, s) for s in (0, 1)] == ["α=0.3", "α=0.8"]
    both = _summary([0.3, 0.3, 0.8], [8, 16, 8], ["greedy"])
    assert setting_label(both, 1) == "α=0.3, 16 drones"
    one = _summary([0.5], [8], ["greedy"])
    assert setting_label(one, 0) == "α=0.5"


def test_unfairness_shows_every_setting_of_a_sweep() -> None:
    summary = _summary([0.2, 0.5, 0.8], [8, 8, 8], ["marops", "greedy"])
    fig = unfairness_figure(summary, ["marops", "greedy"])
    (ax,) = fig.axes
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == ["α=0.2", "α=0.5", "α=0.8"]
    heights = sorted(round(p.get_height(), 6) for p in ax.patches)
    assert heights == sorted(
        round(v, 6) for v in summary.column("delay_unfairness_mean").to_pylist()
    )
    assert [t.get_text() for t in ax.get_xticklabels()] == ["marops", "greedy"]
