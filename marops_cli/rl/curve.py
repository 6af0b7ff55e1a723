"""The training curve as a picture: written beside the actor as ``NAME.curve.png``."""

from __future__ import annotations

import io
from typing import Any

import numpy as np
from matplotlib.figure import Figure  # the object API: no pyplot state, no backend chosen


def curve_png(sidecar: dict[str, Any]) -> bytes:
    """PNG of the mean episode return per update (left) and the held-out daily combined
    cost (docs/method.md §8) of the actor and the baselines at every evaluation (right),
    from the sidecar's ``learning_curve`` and ``evaluations``; the exported evaluation is
    marked."""
    fig = Figure(figsize=(10, 3.8), dpi=100)
    ax1, ax2 = fig.subplots(1, 2)
    lc = sidecar.get("learning_curve") or []
    if lc:
        x = [p["episode"] for p in lc]
        y = np.array([p["reward"] for p in lc], dtype=float)
        ax1.plot(x, y, lw=0.6, color="#4a7bb7", alpha=0.4, label="per update")
        k = max(1, min(25, len(y) // 5))  # a running mean over scenarios and days
        smooth = np.convolve(y, np.ones(k) / k, mode="valid")
        ax1.plot(x[k - 1 :], smooth, lw=1.5, color="#1f3f6e", label=f"mean of {k}")
        ax1.legend(fontsize=8)
    ax1.set_xlabel("episode")
    ax1.set_ylabel("mean return per drone")
    ax1.set_title("training return", fontsize=10)
    evals = sidecar.get("evaluations") or []
    if evals:
        x = [e["episode"] for e in evals]
        for m in [k for k in evals[0] if k != "episode"]:
            ax2.plot(x, [e.get(m, float("nan")) for e in evals], marker="o", ms=3, label=m)
        chosen = sidecar.get("exported_episode")
        if chosen is not None:
            ax2.axvline(chosen, color="grey", ls=":", lw=1)
        ax2.legend(fontsize=8)
    ax2.set_xlabel("episode")
    ax2.set_ylabel("daily combined cost (lower is better)")
    ax2.set_title("held-out days", fontsize=10)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    return buf.getvalue()
