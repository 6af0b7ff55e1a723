"""The inputs every use case takes: data as a file or an in-memory table, depots, fleet."""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias

from ..errors import InputError, not_found, option

if TYPE_CHECKING:
    from ..config import DataConfig
    from ..data.table import LadeTable
    from ..segment.depots import Depots

Data: TypeAlias = "str | Path | Any"
"""A LaDe export: a path (CSV, CSV.gz, Parquet), a pandas DataFrame or a pyarrow Table
with the export's columns."""


def in_memory(data: Any) -> bool:
    """Whether ``data`` is a table in memory rather than a file's path (a ``str`` or
    any ``os.PathLike``)."""
    return not isinstance(data, str | os.PathLike)


DepotsInput: TypeAlias = "str | Path | Mapping[str, Any] | Depots"
"""Depots: a depots file's path, or depots in memory: a depots file's document (the
Python API's ``segment()`` returns one) or a :class:`~marops_cli.segment.depots.Depots`."""
DEPOTS_IN_MEMORY = "depots"
"""What messages call depots given in memory (as the API's keyword names them)."""


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
    """``"121.47,31.23"`` -> (lng, lat), in ASCII digits."""
    from ..config import ascii_number

    if text is None:
        return None
    try:
        lng_s, lat_s = text.split(",")
        lng, lat = ascii_number(lng_s, float), ascii_number(lat_s, float)
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


def given_depots(depots: Any, n_actions: int | None = None) -> Path | Depots:
    """The depots a use case is given (:data:`DepotsInput`): a file's path as it is (the
    scenario reads and checks it), depots in memory checked as a depots file is (errors
    name :data:`DEPOTS_IN_MEMORY`), as a copy the run may annotate. ``n_actions``: the
    action candidates the run gives each depot, refused as for a file when the
    flight-range table would be too large."""
    import dataclasses

    from ..segment.depots import Depots

    if not in_memory(depots):
        return Path(depots)
    if isinstance(depots, Depots):
        given = dataclasses.replace(depots)
    elif isinstance(depots, Mapping):
        given = Depots.from_dict(dict(depots), source=DEPOTS_IN_MEMORY)
    else:
        raise InputError(
            f"{option('depots')} expects a depots file, a depots document or Depots, "
            f"got {type(depots).__name__}"
        )
    given.check_actions(n_actions, DEPOTS_IN_MEMORY)
    return given


def depots_record(depots: Path | Depots) -> dict[str, str]:
    """What the outputs' metadata record of the depots (``depots_file``): a file's name
    and SHA-256; for depots in memory, ``name`` :data:`DEPOTS_IN_MEMORY` and the SHA-256
    of their depots document without its provenance (``meta``), so the same depots give
    the same record whichever object holds them."""
    import hashlib

    from ..io.atomic import dumps_json
    from ..io.meta import file_sha256

    if isinstance(depots, Path):
        return {"name": depots.name, "sha256": file_sha256(depots)}
    doc = dumps_json(depots.to_dict({})).encode("utf-8")
    return {"name": DEPOTS_IN_MEMORY, "sha256": hashlib.sha256(doc).hexdigest()}


def protect_inputs(outputs: Iterable[Path], inputs: Iterable[Any]) -> None:
    """Register the run's input files (no output may replace one, whatever the names:
    ``io/ownership.py``) and check ``outputs`` before any work: not an input, not a
    file marops did not write (without ``--force``), in a folder that can be written."""
    from ..io.ownership import check_outputs, register_inputs

    register_inputs(inputs)
    check_outputs(outputs)
