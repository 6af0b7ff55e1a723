"""Orders of output folders as a reader expects them."""

from __future__ import annotations

import re
from pathlib import Path

__all__ = ["natural_key"]


def natural_key(path: Path) -> list[int | str]:
    """A sort key that orders the numbers in a name by value (hub-9 before hub-10)."""
    parts = re.split(r"(\d+)", path.name)
    # Text and numbers alternate from the same place in every name (re.split puts the
    # numbers at odd positions), so two keys never compare a number with text.
    return [int(p) if k % 2 else p for k, p in enumerate(parts)]
