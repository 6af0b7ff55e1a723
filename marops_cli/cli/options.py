"""Options shared by several commands (one definition, one help text)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

Data = Annotated[Path, typer.Argument(help="LaDe delivery export (CSV or Parquet).")]
Config = Annotated[
    Path | None, typer.Option("--config", help="Planner config TOML; flags override it.")
]
Year = Annotated[int | None, typer.Option("--year", help="Year of the MM-DD times [2022].")]
Strict = Annotated[
    bool, typer.Option("--strict", help="Make any bad row an error instead of dropping it.")
]
Alpha = Annotated[
    float | None,
    typer.Option(
        "--alpha", help="Trade-off weight in (0, 1]: higher saves energy, lower delay [0.5]."
    ),
]
Drones = Annotated[int | None, typer.Option("--drones", help="Fleet size [8].")]
Policy = Annotated[
    str | None,
    typer.Option(
        "--policy",
        help="Flight-range policy: stay, random, greedy, global, or a trained actor "
        "(torchscript:PATH or PATH.pt) [the method's own].",
    ),
]
Seed = Annotated[int | None, typer.Option("--seed", help="Seed for random policies [0].")]
Ordering = Annotated[
    str | None,
    typer.Option(
        "--ordering", help="Visiting order: exact (energy-optimal) or greedy (paper) [exact]."
    ),
]
StrictCover = Annotated[
    bool,
    typer.Option("--strict-cover", help="The paper's exact cover of all candidates when feasible."),
]
