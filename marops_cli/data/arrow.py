"""Arrow column types as the readers judge them."""

from __future__ import annotations

import pyarrow as pa

__all__ = ["is_text"]


def is_text(t: pa.DataType) -> bool:
    """A column of text: Arrow's string or large string (a dictionary column is judged
    by its value type, which the caller unwraps where it accepts one)."""
    return bool(pa.types.is_string(t) or pa.types.is_large_string(t))
