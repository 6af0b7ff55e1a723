"""The application layer: one module per use case, under both the CLI and the Python API.

Each use case is a function over typed inputs (a config, data as a path or an
in-memory table, depots, fleet) that returns a typed result (dataclasses holding
tables and metrics in memory) and reports what it does through a
:class:`~marops_cli.app.progress.Progress` callback. It never prints, never reads
command-line state, and writes files only when it is given an output folder
(docs/decisions.md, "Application layer").
"""

from __future__ import annotations

from .progress import SILENT, Progress, Silent

__all__ = ["SILENT", "Progress", "Silent"]
