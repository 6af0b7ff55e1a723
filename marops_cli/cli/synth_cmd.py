"""``marops synth``: write LaDe-shaped synthetic data."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from . import options as o
from .common import guarded, info


@guarded
def synth_command(
    out: Annotated[Path, typer.Option("--out", help="Output file (.csv, .csv.gz or .parquet).")],
    days: Annotated[int, typer.Option("--days", help="Number of consecutive days.")] = 12,
    seed: Annotated[int, typer.Option("--seed", help="Random seed; same seed, same bytes.")] = 7,
    start: Annotated[
        str, typer.Option("--start", help="First day (0801, 801 or 2022-08-01).")
    ] = "2022-08-01",
    orders_per_day: Annotated[
        float | None,
        typer.Option(
            "--orders-per-day",
            help="Mean city-wide orders per day, at most 1000000 [default: 1800].",
        ),
    ] = None,
    shape: Annotated[
        str,
        typer.Option(
            "--shape",
            help="City layout: hubs, river, corridor or polycentric (docs/method.md §1).",
        ),
    ] = "hubs",
    fmt: Annotated[
        str | None,
        typer.Option("--format", help="csv or parquet [default: from the file suffix, else csv]."),
    ] = None,
    force: o.Force = False,
) -> None:
    """Generate LaDe-shaped delivery data (all 17 columns, the real export's formats and quirks)."""
    from ..app.synth import synth as generate
    from ..io.ownership import replacing_foreign_files

    with replacing_foreign_files(force):
        res = generate(
            days=days,
            seed=seed,
            start=start,
            orders_per_day=orders_per_day,
            shape=shape,
            out=out,
            fmt=fmt,
        )
    info(
        f"wrote {res.path} ({res.table.num_rows:,} rows, {days} day{'s' * (days != 1)} from "
        f"{res.start.isoformat()}, {shape} city)"
    )
