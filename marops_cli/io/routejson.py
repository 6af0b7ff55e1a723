"""Reading a JSON route file back (``stops.json``, ``routes.json``): the report, the API's
kept day and the judgment of whose a JSON file is read it under one cap."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from ..config import MAX_DAY_STOPS
from ..data.jsonfile import (
    MAX_SMALL_FILE,
    parse_json,
    parse_json_at,
    read_document,
    read_text_at_most,
)

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


HEAD_BYTES = 1 << 20
"""Bytes of a route file's beginning read for its metadata alone (a run's ``meta`` is a
few kilobytes: its config and identity)."""
_FIRST_MEMBER = re.compile(
    r'\A\s*\{\s*(?:"type"\s*:\s*"FeatureCollection"\s*,\s*)?"(meta|marops)"\s*:\s*'
)


def route_json_meta(path: Path, key: str) -> Any:
    """The member ``key`` (``meta``, or a GeoJSON's ``marops``) of the JSON file ``path``
    without reading the rest of it: a file up to the small-file cap is parsed whole (its
    members in any order); a larger one, as a day's route file can be, only from its
    first :data:`HEAD_BYTES`, where marops writes that member first (after a GeoJSON's
    ``type``). A file where it is
    not found is a ``KeyError``; a malformed one a ``ValueError``; an unreadable one an
    ``OSError``."""
    if path.stat().st_size <= MAX_SMALL_FILE:
        doc = parse_json(read_text_at_most(path, f"{path.stem} file", MAX_SMALL_FILE))
        if not isinstance(doc, dict):
            raise KeyError(key)
        return doc[key]
    with open(path, "rb") as fh:
        head = fh.read(HEAD_BYTES).decode("utf-8-sig", errors="replace")
    first = _FIRST_MEMBER.match(head)
    if first is None or first.group(1) != key:
        raise KeyError(key)
    return parse_json_at(head, first.end())
