"""Reading a JSON route file back (``stops.json``, ``routes.json``): the report, the API's
kept day and the judgment of whose a JSON file is read it under one cap."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..config import MAX_DAY_STOPS
from ..data.jsonfile import read_document

ROUTE_ROW_BYTES = 1024
"""Bytes a row of a JSON route file takes at most as marops writes it, with an order id
of a few dozen characters (a stop's row with a 12-character id, indented, is about 720)."""
MAX_ROUTE_JSON = MAX_DAY_STOPS * ROUTE_ROW_BYTES
"""Bytes a ``stops.json`` or ``routes.json`` read back may have (about 3.7 GiB): a row
for each of the most stops of a day (:data:`~marops_cli.config.MAX_DAY_STOPS`), as the
Parquet route files are bounded by their rows. A larger file, or a device that never
ends, is refused before it fills the memory."""


def read_route_json(path: Path) -> Any:
    """The parsed ``stops.json`` or ``routes.json`` ``path`` (a report's, a kept day's
    read back): a missing, unreadable or malformed file, or one larger than
    :data:`MAX_ROUTE_JSON`, is an :class:`~marops_cli.errors.InputError` naming it."""
    return read_document(path, f"{path.stem} file", "json", cap=MAX_ROUTE_JSON)
