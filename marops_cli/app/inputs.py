"""The inputs every use case takes: data as a file or an in-memory table, depots, fleet."""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias

from ..errors import InputError, not_found, option

if TYPE_CHECKING:
    from ..config import DataConfig
    from ..data.table import LadeTable

Data: TypeAlias = "str | Path | Any"
"""A LaDe export: a path (CSV, CSV.gz, Parquet), a pandas DataFrame or a pyarrow Table
with the export's columns."""


def in_memory(data: Any) -> bool:
    """Whether ``data`` is a table in memory rather than a file's path (a ``str`` or
    any ``os.PathLike``)."""
    return not isinstance(data, str | os.PathLike)


def data_name(data: Any) -> str:
    """What messages call the data: the file's name, or ``DataFrame`` / ``Table``."""
    from ..data.reader import IN_MEMORY  # pyarrow loads with the first read, not the CLI

    if not in_memory(data):
        return Path(data).name
    return IN_MEMORY[1] if type(data).__name__ == "Table" else IN_MEMORY[0]


def require_input(path: str | Path) -> None:
    """Stop at once when the data file is missing or is a folder."""
    path = Path(path)
    if not path.exists():
        raise not_found(path)
    if path.is_dir():
        raise InputError("is a folder, expected a LaDe CSV or Parquet file", file=path)


def parse_center(text: str | None) -> tuple[float, float] | None:
    """``"121.47,31.23"`` -> (lng, lat)."""
    if text is None:
        return None
    try:
        lng_s, lat_s = text.split(",")
        lng, lat = float(lng_s), float(lat_s)
    except ValueError:
        raise InputError(
            f"{option('center')} expects LNG,LAT (e.g. 121.47,31.23), got {text!r}"
        ) from None
    if not (-180 <= lng <= 180 and -90 <= lat <= 90):
        raise InputError(f"{option('center')} {text!r} is not a valid LNG,LAT")
    return lng, lat


def check_format(fmt: str) -> None:
    """Route files are written as ``parquet`` or ``json``."""
    if fmt not in ("parquet", "json"):
        raise InputError(f"{option('fmt')} expects parquet or json, got {fmt!r}")


def read_data(data: Any, cfg: DataConfig) -> LadeTable:
    """The kept rows of ``data`` (a file or a table in memory) and its drop report."""
    from ..data.reader import read_lade, read_lade_table

    if in_memory(data):
        return read_lade_table(data, cfg)
    return read_lade(Path(data), cfg)


def protect_inputs(outputs: Iterable[Path], inputs: Iterable[Any]) -> None:
    """Register the run's input files (no output may replace one, whatever the names:
    ``io/ownership.py``) and check ``outputs`` before any work: not an input, not a
    file marops did not write (without ``--force``), in a folder that can be written."""
    from ..io.ownership import check_outputs, register_inputs

    register_inputs(inputs)
    check_outputs(outputs)
