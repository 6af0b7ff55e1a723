"""Options shared by several commands (one definition, one help text)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..methods import method_names, policy_names

METHOD_NAMES = method_names()  # every registered method (marops_cli/methods.py)
Data = Annotated[
    Path,
    typer.Argument(
        metavar="DATA",
        help="LaDe delivery export (CSV or Parquet); - reads it from standard input.",
    ),
]
Config = Annotated[
    Path | None,
    typer.Option(
        "--config", envvar="MAROPS_CONFIG", help="Planner config TOML; flags override it."
    ),
]
Method = Annotated[
    str,
    typer.Option(
        "--method",
        help=f"One of {METHOD_NAMES} (docs/method.md §7) [default: marops].",
        show_default=False,
    ),
]
Year = Annotated[
    int | None,
    typer.Option("--year", envvar="MAROPS_YEAR", help="Year of the MM-DD times [default: 2022]."),
]
Strict = Annotated[
    bool, typer.Option("--strict", help="Make any bad row an error instead of dropping it.")
]
Alpha = Annotated[
    float | None,
    typer.Option(
        "--alpha",
        envvar="MAROPS_ALPHA",
        help="Trade-off weight in [0.001, 1]: higher saves energy, lower delay [default: 0.5].",
    ),
]
Drones = Annotated[
    int | None, typer.Option("--drones", envvar="MAROPS_DRONES", help="Fleet size [default: 8].")
]
Area = Annotated[
    str | None,
    typer.Option(
        "--area",
        envvar="MAROPS_AREA",
        help="square: one study square (the paper's experiment); hubs: hubs placed over "
        "the whole export, each with its depots and share of the fleet, one folder each "
        "[default: [data] area, hubs; one square with --depots or --fleet].",
    ),
]
CityDrones = Annotated[
    int | None,
    typer.Option(
        "--city-drones",
        help="Over hubs: the city's fleet, shared out by the hubs' demand "
        "[default: --drones per hub].",
    ),
]
FleetFile = Annotated[
    Path | None,
    typer.Option(
        "--fleet",
        help="Fleet file (TOML or JSON): each drone's depot and type, or drones per type "
        "(docs/outputs.md) [default: --drones drones of the [energy] type over the busiest "
        "depots].",
    ),
]
Policy = Annotated[
    str | None,
    typer.Option(
        "--policy",
        help=f"Flight-range policy: {policy_names()}, or a trained actor (PATH.pt, an "
        "actor's weights PATH.safetensors, or torchscript:PATH) [default: the method's own].",
    ),
]
TrustActor = Annotated[
    bool,
    typer.Option(
        "--trust-actor",
        help="Load a TorchScript actor (.pt) that has no weights file (.safetensors) beside "
        "it: this runs code of the file, so only for a file whose author you trust "
        "(docs/method.md §6).",
    ),
]
Seed = Annotated[
    int | None,
    typer.Option("--seed", envvar="MAROPS_SEED", help="Seed for random policies [default: 0]."),
]
Ordering = Annotated[
    str | None,
    typer.Option(
        "--ordering",
        help="Visiting order: exact (energy-optimal) or greedy (paper) [default: exact].",
    ),
]
StrictCover = Annotated[
    bool,
    typer.Option("--strict-cover", help="The paper's exact cover of all candidates when feasible."),
]
Quiet = Annotated[
    bool,
    typer.Option(
        "--quiet", "-q", envvar="MAROPS_QUIET", help="Only warnings and errors on stderr."
    ),
]
Json = Annotated[
    bool,
    typer.Option(
        "--json",
        envvar="MAROPS_JSON",
        help="Print the run's summary as one JSON document on stdout (no tables, no progress).",
    ),
]
Tz = Annotated[
    str | None,
    typer.Option(
        "--tz",
        envvar="MAROPS_TZ",
        help="Time zone of the data's local times [default: Asia/Shanghai].",
    ),
]
Geojson = Annotated[
    bool,
    typer.Option(
        "--geojson",
        help="Also write routes.geojson: one LineString per route (a MultiLineString cut "
        "at 180° across the antimeridian).",
    ),
]
Format = Annotated[
    str,
    typer.Option(
        "--format", help="Route files: parquet or json [default: parquet].", show_default=False
    ),
]
Force = Annotated[
    bool,
    typer.Option("--force", help="Replace existing output files, even ones marops did not write."),
]
OutFolder = Annotated[Path, typer.Option("--out", help="Output folder.")]
Workers = Annotated[
    int,
    typer.Option(
        "--workers",  # its range is checked with the run's (workers/pool.py: check_workers)
        help="Worker processes, 1 to 256 (with --scheduler local: the cluster's); without "
        "--scheduler, a single job runs here.",
    ),
]
Scheduler = Annotated[
    str | None,
    typer.Option(
        "--scheduler",
        help="Run the jobs on a Dask cluster: its scheduler's address (tcp://HOST:8786), "
        "or local for a cluster of --workers processes on this machine; needs "
        "pip install 'marops[cluster]' (README.md, Sweeps on a cluster).",
    ),
]
Report = Annotated[
    bool,
    typer.Option(
        "--report",
        help="Also write report.html: an interactive page of the run that opens offline "
        "(docs/report.md; needs pip install 'marops[report]').",
    ),
]
