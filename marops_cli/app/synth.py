"""Write LaDe-shaped synthetic data (``synth``, docs/method.md §1)."""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from ..config import DataConfig, count, option_error, value_range
from ..errors import InputError

if TYPE_CHECKING:
    import pyarrow as pa


@dataclass(frozen=True)
class Synthesized:
    """The generated rows (all 17 LaDe columns), their first day and the file written."""

    table: pa.Table
    start: dt.date
    path: Path | None


def synth(
    *,
    days: int = 12,
    seed: int = 7,
    start: str | dt.date = "2022-08-01",
    orders_per_day: float | None = None,
    shape: str = "hubs",
    out: str | Path | None = None,
    fmt: str | None = None,
) -> Synthesized:
    """``days`` consecutive days of a ``shape`` city from ``start`` (same seed, same
    rows); with ``out`` written as CSV or Parquet (``fmt``, else from the suffix), CSV
    gzipped when ``out`` ends in ``.gz``."""
    from pydantic import ValidationError

    from ..data.dates import parse_day
    from ..data.synth import SynthConfig, file_format, generate, write

    if fmt not in (None, "csv", "parquet"):
        raise InputError(f"--format expects csv or parquet, got {fmt!r}")
    first = (
        start if isinstance(start, dt.date) else parse_day(start, 2022, "--start", year_option=None)
    )
    try:  # a file the reader could not read with its own --year
        DataConfig(year=first.year)
    except ValidationError:
        raise InputError(
            f"invalid option --start: {first.isoformat()} is in a year marops does not read "
            f"({str(value_range('data', 'year')).replace('x', 'year')}, --year)"
        ) from None
    fields: dict[str, object] = {"days": days, "seed": seed, "start": first, "shape": shape}
    if orders_per_day is not None:
        fields["orders_per_day"] = orders_per_day
    try:
        cfg = SynthConfig(**fields)  # type: ignore[arg-type]
    except ValidationError as exc:  # the flag (and keyword) that set it
        raise option_error(exc, SynthConfig, lambda name: name.replace("_", "-")) from None
    last = first + dt.timedelta(days=cfg.days - 1)  # days within its range: a real date
    if last.year != first.year:  # LaDe's MM-DD times would run 12-31 into 01-01
        raise InputError(
            f"invalid option --days: {days} days from {first.isoformat()} run past the end of "
            "its year, which LaDe's month-day times cannot tell apart"
        )
    _check_memory(cfg.days, cfg.orders_per_day)
    if out is None:
        return Synthesized(generate(cfg), first, None)
    from ..io import output_set
    from ..io.atomic import check_unheld
    from ..io.ownership import check_outputs

    out = Path(out)
    last_suffix = out.suffix.lower()
    if last_suffix in _OTHER_COMPRESSION:  # would hold plain CSV under a name that lies
        raise InputError(
            f"invalid option --out: marops writes CSV, gzipped CSV (.csv.gz) or Parquet, "
            f"not {last_suffix[1:]}; name the file .csv, .csv.gz or .parquet",
            file=out,
        )
    suffix_fmt, gzipped = file_format(out)
    if fmt == "csv" and suffix_fmt == "parquet" and not gzipped:  # read as Parquet
        raise InputError(
            f"invalid option --format: csv under a {last_suffix} name, which the reader "
            "takes for Parquet; name the file .csv (or .csv.gz), or leave --format out",
            file=out,
        )
    kind: Literal["csv", "parquet"] = "parquet" if (fmt or suffix_fmt) == "parquet" else "csv"
    if kind == "parquet" and gzipped:  # the reader would take gzip for CSV
        raise InputError(
            "invalid option --out: a .gz file is gzipped CSV, and Parquet compresses its "
            "own columns; write .parquet, or .csv.gz for gzipped CSV",
            file=out,
        )
    # Never a file marops did not write. The data carries no marops metadata, not even
    # as Parquet (a reader cannot tell it from an export): the journal records it.
    check_unheld(out)  # not into a folder another run holds
    check_outputs([out], journal=True)
    table = generate(cfg)
    with output_set() as files:
        files.write_with(out, lambda tmp: write(table, tmp, kind, gzipped=gzipped), journal=True)
    return Synthesized(table, first, out)


_OTHER_COMPRESSION = frozenset({".bz2", ".xz", ".zip", ".zst", ".lz4", ".7z", ".lzma", ".tgz"})
"""Suffixes of compressions other than gzip: synth writes none of them."""

SYNTH_ROW_BYTES = 700
"""Memory the generator holds per row at its peak, with the writer's copy (measured: 0.87
GB for 1.05 million rows, 2.88 GB for 4.02 million, CSV and Parquet alike)."""


def _check_memory(days: int, orders_per_day: float) -> None:
    """Refuse, before any work, a file the machine cannot hold while it is made: the
    generator builds the whole table, and a run past the memory is killed by the system
    with no word (docs/outputs.md)."""
    rows = 1.1 * days * orders_per_day  # the days' volume varies around the mean
    need = 0.2e9 + SYNTH_ROW_BYTES * rows
    have = available_memory()
    if have is not None and need > have:
        raise InputError(
            f"invalid option --orders-per-day: {count(days, 'day')} of "
            f"{orders_per_day:,.0f} orders need about {need / 1e9:,.1f} GB of memory while "
            f"they are made, and {have / 1e9:,.1f} GB is available; ask fewer --days or "
            "--orders-per-day"
        )


def available_memory() -> int | None:
    """Bytes of memory the system can give without swapping (Linux's MemAvailable);
    None where it does not say."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None
