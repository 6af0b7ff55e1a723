"""``marops report``: the interactive report.html of an existing output folder."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..io.ownership import allow_replacing_foreign
from . import options as o
from .common import STATE, emit_json, guarded, info, set_output
from .progress import Terminal


def wrote_pages(files: list[Path]) -> str:
    """The closing line: the pages written; for many (a day and hub folder each), their
    count, the first and the last."""
    if len(files) <= 8:
        return "wrote " + ", ".join(map(str, files))
    return f"wrote {len(files)} files: {files[0]}, …, {files[-1]}"


@guarded
def report_command(
    folder: Annotated[
        Path,
        typer.Argument(
            metavar="DIR", help="Output folder of replay-day, plan-window or evaluate (its --out)."
        ),
    ],
    depots: Annotated[
        Path | None,
        typer.Option(
            "--depots",
            help="The run's depots.json: draw every depot and the service areas "
            "[default: the depots the routes use].",
        ),
    ] = None,
    force: o.Force = False,
    quiet: o.Quiet = False,
    as_json: o.Json = False,
) -> None:
    """Write report.html into an output folder (and each of its day and hub folders): an
    interactive page of the run that opens offline (docs/report.md)."""
    set_output(quiet, as_json)
    allow_replacing_foreign(force)
    from ..app.report import make_report

    written = make_report(folder, depots=depots, progress=Terminal())
    info(wrote_pages(written))
    if STATE["json"]:
        emit_json({"command": "report", "files": [str(p) for p in written]})
