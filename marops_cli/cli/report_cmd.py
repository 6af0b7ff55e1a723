"""``marops report``: the interactive report.html of an existing output folder."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..io.ownership import allow_replacing_foreign
from . import options as o
from .common import STATE, emit_json, guarded, info, set_output


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

    written = make_report(folder, depots=depots)
    info("wrote " + ", ".join(str(p) for p in written))
    if STATE["json"]:
        emit_json({"command": "report", "files": [str(p) for p in written]})
