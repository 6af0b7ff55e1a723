"""Options shared by several commands (one definition, one help text). The options that
set a planner config field come from the table of marops_cli/app/options.py: their types
here (``Alpha``) are its entries, and :func:`takes_options` gives a command every option
of its use case."""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, TypeVar

import typer

from ..app.options import OPTIONS, LiveSignature, OptionSpec, split_options, with_options
from ..methods import method_names

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
FleetFile = Annotated[
    Path | None,
    typer.Option(
        "--fleet",
        help="Fleet file (TOML or JSON): each drone's depot and type, or drones per type "
        "(docs/outputs.md) [default: --drones drones of the [energy] type over the busiest "
        "depots].",
    ),
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
        help="Worker processes, 1 to 256, at most 4 per CPU run (with --scheduler local: "
        "the cluster's); without --scheduler, a single job runs here.",
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


# --- the table's options (marops_cli/app/options.py) -----------------------------------


def table_option(name: str, use: str | None = None) -> Any:
    """The flag of the table's option ``name`` (its help as use case ``use`` words it)."""
    spec = OPTIONS[name]
    return typer.Option(spec.flag_text, envvar=spec.envvar, help=spec.help_text(use))


def _parameter(use: str) -> Callable[[OptionSpec], inspect.Parameter]:
    def parameter(spec: OptionSpec) -> inspect.Parameter:
        kind: Any = bool if spec.switch else spec.type | None
        return inspect.Parameter(
            spec.param,
            inspect.Parameter.POSITIONAL_OR_KEYWORD,
            default=False if spec.switch else None,
            annotation=Annotated[kind, table_option(spec.name, use)],
        )

    return parameter


# A command names the options it places in its help with these (their static types for
# the type checker); what Typer reads is the table's entry, as the use case words it.
Year = Annotated[int | None, table_option("year")]
Strict = Annotated[bool, table_option("strict")]
Tz = Annotated[str | None, table_option("tz")]
SizeKm = Annotated[float | None, table_option("size_km")]
Center = Annotated[str | None, table_option("center")]
Area = Annotated[str | None, table_option("area")]
NDepots = Annotated[int | None, table_option("n_depots")]
Segmentation = Annotated[str | None, table_option("segmentation")]
Segment = Annotated[str | None, table_option("segment")]
Actions = Annotated[int | None, table_option("actions")]
SegmentSeed = Annotated[int | None, table_option("segment_seed")]
Alpha = Annotated[float | None, table_option("alpha")]
Ordering = Annotated[str | None, table_option("ordering")]
StrictCover = Annotated[bool, table_option("strict_cover")]
Drones = Annotated[int | None, table_option("drones")]
CityDrones = Annotated[int | None, table_option("city_drones")]
Seed = Annotated[int | None, table_option("seed")]
Policy = Annotated[str | None, table_option("policy")]
TrustActor = Annotated[bool, table_option("trust_actor")]

F = TypeVar("F", bound=Callable[..., Any])


def takes_options(use: str) -> Callable[[F], F]:
    """A command of use case ``use`` (``plan_window``) with every option the table gives
    it: the function's parameters named after one place it in the help, the others come
    before ``--quiet``; all of them reach the function gathered in its keyword-only
    ``options`` (name -> value, for ``planner_config``), those it names by name too. The
    command's signature is made from the table when Typer asks for it, so an option
    registered before the command line is built is the command's."""

    def decorate(fn: F) -> F:
        own = inspect.signature(fn, eval_str=True)

        @functools.wraps(fn)
        def command(**kwargs: Any) -> Any:
            mine, options = split_options(use, kwargs, own)
            return fn(**mine, options=options)

        made = functools.partial(with_options, own, use, _parameter(use), ("quiet", "as_json"))
        command.__signature__ = LiveSignature(made)  # type: ignore[attr-defined]
        return command  # type: ignore[return-value]

    return decorate
