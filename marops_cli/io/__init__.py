"""Writers: atomic output sets, metadata, Parquet and JSON tables."""

from .atomic import OutputSet, dumps_json, output_set
from .meta import file_sha256, run_meta

__all__ = ["OutputSet", "dumps_json", "file_sha256", "output_set", "run_meta"]
