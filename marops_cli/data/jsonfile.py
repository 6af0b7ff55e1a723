"""Reading the small JSON files marops takes as input (depots, fleet, policy sidecar)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from ..errors import InputError


def read_json(path: str | Path, what: str) -> Any:
    """The parsed document; a missing or malformed file is an :class:`InputError` naming it."""
    p = Path(path)
    try:
        return json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise InputError(f"{what} not found", file=p) from exc
    except IsADirectoryError as exc:
        raise InputError(f"{what} is a folder, expected a JSON file", file=p) from exc
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{what} is not valid JSON ({exc})", file=p) from exc


def json_number(value: Any, path: str | Path, column: str, *, whole: bool = False) -> float:
    """``value`` from a JSON or TOML input as a finite number (``whole``: a whole one);
    anything else (text, NaN, infinity) is an :class:`InputError` naming the file and the
    key."""
    kind = "whole number" if whole else "number"
    ok = isinstance(value, int | float) and not isinstance(value, bool)
    if not ok or not math.isfinite(value) or (whole and int(value) != value):
        raise InputError(f"expected a {kind}, got {value!r}", file=path, column=column)
    return float(value)
