"""Reading the small JSON files marops takes as input (depots, fleet, policy sidecar)."""

from __future__ import annotations

import json
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
