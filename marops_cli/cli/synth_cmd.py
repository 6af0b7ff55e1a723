"""``marops synth``: write LaDe-shaped synthetic data."""

from __future__ import annotations

import datetime as dt
from pathlib import Path
from typing import Annotated

import typer
from pydantic import ValidationError

from ..errors import InputError
from .common import guarded, info


@guarded
def synth(
    out: Annotated[Path, typer.Option("--out", help="Output file (.csv or .parquet).")],
    days: Annotated[int, typer.Option("--days", help="Number of consecutive days.")] = 12,
    seed: Annotated[int, typer.Option("--seed", help="Random seed; same seed, same bytes.")] = 7,
    start: Annotated[
        str, typer.Option("--start", help="First day (0801, 801 or 2022-08-01).")
    ] = "2022-08-01",
    orders_per_day: Annotated[
        float | None, typer.Option("--orders-per-day", help="Mean city-wide orders per day [1800].")
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
        typer.Option("--format", help="csv or parquet [from the file suffix, else csv]."),
    ] = None,
) -> None:
    """Generate LaDe-shaped delivery data (all 17 columns, the real export's formats and quirks)."""
    from ..data.dates import parse_day
    from ..data.synth import SynthConfig, generate, write

    if fmt not in (None, "csv", "parquet"):
        raise InputError(f"--format expects csv or parquet, got {fmt!r}")
    first: dt.date = parse_day(start, 2022)
    fields: dict[str, object] = {"days": days, "seed": seed, "start": first, "shape": shape}
    if orders_per_day is not None:
        fields["orders_per_day"] = orders_per_day
    try:
        cfg = SynthConfig(**fields)  # type: ignore[arg-type]
    except ValidationError as exc:
        err = exc.errors()[0]
        raise InputError(f"invalid option {err['loc'][0]}: {err['msg']}") from None
    table = generate(cfg)
    path = write(table, out, fmt)  # type: ignore[arg-type]
    info(
        f"wrote {path} ({table.num_rows:,} rows, {days} days from {first.isoformat()}, "
        f"{shape} city)"
    )
