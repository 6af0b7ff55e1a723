"""Writers: atomic output sets, metadata, Parquet and JSON tables."""

from .atomic import OutputSet, Terminated, dumps_json, folder_lock, output_set
from .meta import file_sha256, run_meta

__all__ = [
    "OutputSet",
    "Terminated",
    "dumps_json",
    "file_sha256",
    "folder_lock",
    "output_set",
    "run_meta",
]
