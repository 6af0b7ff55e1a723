"""Arrow column types as the readers judge them."""

from __future__ import annotations

import os
from pathlib import Path

import pyarrow as pa

__all__ = [
    "is_text",
    "native_file",
    "parquet_rows",
    "read_csv_file",
    "read_parquet",
    "read_parquet_schema",
]


def is_text(t: pa.DataType) -> bool:
    """A column of text: Arrow's string or large string (a dictionary column is judged
    by its value type, which the caller unwraps where it accepts one)."""
    return bool(pa.types.is_string(t) or pa.types.is_large_string(t))


def native_file(path: str | Path, mode: str = "r") -> pa.NativeFile:
    """``path`` opened as a pyarrow file by its bytes (``mode`` ``r`` or ``w``): pyarrow's
    own opening of a path fails on a name that is not UTF-8 (an archive's GBK names)."""
    return pa.OSFile(os.fsencode(path), mode=mode)


def read_parquet(path: str | Path, columns: list[str] | None = None) -> pa.Table:
    """``pq.read_table`` of a file of any name (:func:`native_file`)."""
    import pyarrow.parquet as pq

    with native_file(path) as f:
        return pq.read_table(f, columns=columns)


def read_parquet_schema(path: str | Path) -> pa.Schema:
    """``pq.read_schema`` of a file of any name (:func:`native_file`)."""
    import pyarrow.parquet as pq

    with native_file(path) as f:
        return pq.read_schema(f)


def parquet_rows(path: str | Path) -> int:
    """The rows a Parquet file holds, as its footer says (nothing else is read)."""
    import pyarrow.parquet as pq

    with native_file(path) as f:
        return int(pq.ParquetFile(f).metadata.num_rows)


def read_csv_file(path: str | Path) -> pa.Table:
    """``pyarrow.csv.read_csv`` of a file of any name (:func:`native_file`)."""
    import pyarrow.csv as pacsv

    with native_file(path) as f:
        return pacsv.read_csv(f)
