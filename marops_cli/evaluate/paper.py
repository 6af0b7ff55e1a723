"""The paper's Table III (basic scenario: 16 areas, 8 drones, 4 actions), for comparison.

Values are mean and standard deviation over the paper's 40 runs (docs/method.md §9).
"""

from __future__ import annotations

import pyarrow as pa

from .report import TABLE_ROWS, mean_pm_std

# Our method name -> the paper's column.
PAPER_NAMES: dict[str, str] = {
    "ops-global": "OPS-global",
    "ops-random": "OPS-random",
    "mappo": "MAPPO",
    "squares": "Squares",
    "marops": "MAR-OPS",
}

# metric -> our method name -> (mean, std).
TABLE3: dict[str, dict[str, tuple[float, float]]] = {
    "mean_energy_kj": {
        "ops-global": (1551.0, 106.0),
        "ops-random": (662.0, 40.4),
        "mappo": (664.3, 33.2),
        "squares": (1768.0, 126.7),
        "marops": (669.1, 33.2),
    },
    "avg_delay_h": {
        "ops-global": (0.67, 0.20),
        "ops-random": (1.17, 0.16),
        "mappo": (1.46, 0.10),
        "squares": (1.15, 0.11),
        "marops": (0.88, 0.10),
    },
    "combined_cost": {
        "ops-global": (0.66, 0.09),
        "ops-random": (0.57, 0.06),
        "mappo": (0.67, 0.04),
        "squares": (0.87, 0.07),
        "marops": (0.48, 0.04),
    },
    "delay_unfairness": {
        "ops-global": (0.21, 0.01),
        "ops-random": (0.60, 0.02),
        "mappo": (0.34, 0.02),
        "squares": (0.56, 0.08),
        "marops": (0.41, 0.01),
    },
    "runtime_s": {
        "ops-global": (6.23, 0.11),
        "ops-random": (0.28, 0.04),
        "mappo": (0.38, 0.02),
        "squares": (0.46, 0.02),
        "marops": (0.46, 0.02),
    },
    "avg_early_h": {
        "ops-global": (0.03, 0.06),
        "ops-random": (0.52, 0.17),
        "mappo": (1.03, 0.05),
        "squares": (0.11, 0.04),
        "marops": (0.17, 0.06),
    },
}


def paper_table(summary: pa.Table, setting: int = 0) -> str:
    """Markdown: Table III beside ours, a paper and an ours column per method of the paper.

    Methods of ours that the paper lacks (greedy, stay, myopic) follow as ours-only columns.
    """
    rows = {r["method"]: r for r in summary.to_pylist() if r["setting"] == setting}
    extra = [m for m in rows if m not in PAPER_NAMES]
    head = ["metric"]
    for m, name in PAPER_NAMES.items():
        head += [f"{name} paper", f"{m} ours"]
    head += [f"{m} ours" for m in extra]
    lines = ["| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
    for spec in TABLE_ROWS:
        key, fmt = spec.name, spec.fmt
        if key not in TABLE3:
            continue
        cells = [spec.label]
        for m in PAPER_NAMES:
            mean, std = TABLE3[key][m]
            cells.append(f"{fmt.format(mean)} ± {fmt.format(std)}")
            cells.append(mean_pm_std(rows[m], key, fmt) if m in rows else "not run")
        cells += [mean_pm_std(rows[m], key, fmt) for m in extra]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
