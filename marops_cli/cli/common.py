"""Shared CLI plumbing: error handling, consoles, option parsing helpers."""

from __future__ import annotations

import functools
import json
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn, TypeVar

import typer
from rich.console import Console
from rich.table import Table

from ..config import PlannerConfig, load_config, override
from ..data.table import DropReport
from ..errors import InputError, MaropsError


def plain_output() -> bool:
    """Plain text for machines and logs: when stdout or stderr is not a terminal, when
    ``NO_COLOR`` is set, ``TERM=dumb``, or ``MAROPS_PLAIN=1``."""
    env = os.environ
    if env.get("MAROPS_PLAIN", "") not in ("", "0"):
        return True
    if "NO_COLOR" in env or env.get("TERM") == "dumb":
        return True
    return not (sys.stdout.isatty() and sys.stderr.isatty())


PLAIN = plain_output()
# In plain mode nothing wraps (lines stay whole in a log) and tables have no box drawing.
_WIDE = 1_000
console = Console(
    stderr=True, highlight=False, width=_WIDE if PLAIN else None, soft_wrap=PLAIN, no_color=PLAIN
)
"""Messages and progress (stderr)."""
out = Console(highlight=False, width=_WIDE if PLAIN else None, soft_wrap=PLAIN, no_color=PLAIN)
"""Result tables (stdout), so a cron job's log keeps them whole."""
STATE: dict[str, bool] = {"debug": False, "quiet": False, "json": False, "silent": False}
"""``silent``: the Python API runs a command; nothing is printed, warnings are warnings."""


def set_output(quiet: bool = False, as_json: bool = False) -> None:
    """Apply a command's ``--quiet`` and ``--json`` (every invocation sets both)."""
    STATE["quiet"], STATE["json"] = bool(quiet), bool(as_json)


def info(message: str) -> None:
    """A progress or status line on stderr; silent with ``--quiet`` or ``--json``."""
    if not (STATE["quiet"] or STATE["json"] or STATE["silent"]):
        console.print(message)


def warn(message: str) -> None:
    """A warning on stderr (shown with ``--quiet`` and ``--json`` too)."""
    if STATE["silent"]:
        import warnings

        warnings.warn(message, stacklevel=2)
        return
    console.print(f"warning: {message}")


def emit_json(doc: Any) -> None:
    """The run's summary as one JSON document on stdout (``--json``)."""
    text = json.dumps(_finite(doc), indent=2, sort_keys=False, default=str, allow_nan=False)
    sys.stdout.write(text + "\n")
    sys.stdout.flush()


def _finite(doc: Any) -> Any:
    """NaN and infinities as null: strict JSON readers (jq, JavaScript) reject them."""
    if isinstance(doc, float):
        return doc if doc == doc and abs(doc) != float("inf") else None
    if isinstance(doc, dict):
        return {k: _finite(v) for k, v in doc.items()}
    if isinstance(doc, list | tuple):
        return [_finite(v) for v in doc]
    return doc


def table(title: str, **kwargs: Any) -> Table:
    """A result table: rich boxes in a terminal, plain aligned columns otherwise."""
    if PLAIN:
        kwargs.setdefault("box", None)
        kwargs.setdefault("show_edge", False)
        kwargs.setdefault("pad_edge", False)
    return Table(title=title, title_justify="left", **kwargs)


def show_table(t: Table) -> None:
    """Print a result table on stdout unless ``--json`` replaces it."""
    if not (STATE["json"] or STATE["silent"]):
        out.print(t)


F = TypeVar("F", bound=Callable[..., Any])


def guarded(fn: F) -> F:
    """Turn library errors into one line on stderr and the exit code of docs/outputs.md."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except MaropsError as exc:
            if STATE["debug"]:
                raise
            typer.echo(f"marops: error: {exc}", err=True)
            raise typer.Exit(exc.exit_code) from None
        except OSError as exc:
            if STATE["debug"]:
                raise
            typer.echo(f"marops: error: {exc}", err=True)
            raise typer.Exit(1) from None
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM (Terminated)
            stopped(exc)

    return wrapper  # type: ignore[return-value]


def stopped(exc: KeyboardInterrupt, kept: str = "") -> NoReturn:
    """Ctrl-C or SIGTERM (:class:`~marops_cli.io.atomic.Terminated`): one line on stderr,
    with what the run keeps when it says, and exit 130 (143 for SIGTERM)."""
    from ..io.atomic import Terminated

    term = isinstance(exc, Terminated)
    how = "terminated" if term else "interrupted"
    typer.echo(f"marops: {how}; {kept}" if kept else f"marops: {how}", err=True)
    raise typer.Exit(143 if term else 130) from None


def parse_center(text: str | None) -> tuple[float, float] | None:
    """``"121.47,31.23"`` -> (lng, lat)."""
    if text is None:
        return None
    try:
        lng_s, lat_s = text.split(",")
        lng, lat = float(lng_s), float(lat_s)
    except ValueError:
        raise InputError(f"--center expects LNG,LAT (e.g. 121.47,31.23), got {text!r}") from None
    if not (-180 <= lng <= 180 and -90 <= lat <= 90):
        raise InputError(f"--center {text!r} is not a valid LNG,LAT")
    return lng, lat


def make_config(config: Path | None, **overrides: Any) -> PlannerConfig:
    """The TOML config (or defaults) with command-line flags applied on top."""
    return override(load_config(config), **overrides)


def refuse_overwriting_inputs(outputs: list[Path], **inputs: Path | None) -> None:
    """Stop before any work when an output would replace an input file (``--out DATA``)."""
    seen = {}
    for flag, path in inputs.items():
        if path is not None and Path(path).exists():
            seen[Path(path).resolve()] = flag.replace("_", "-")
    for out_path in outputs:
        hit = seen.get(Path(out_path).resolve())
        if hit is not None:
            raise InputError(
                f"would overwrite the input given as {hit}; choose another --out", file=out_path
            )


def require_input(path: Path) -> None:
    if not path.exists():
        raise InputError("file not found", file=path)
    if path.is_dir():
        raise InputError("is a folder, expected a LaDe CSV or Parquet file", file=path)


def print_drop_report(report: DropReport, name: str) -> None:
    """Tell the user which rows were dropped and why (docs/method.md §1)."""
    if report.n_dropped == 0:
        info(f"{name}: {report.total:,} rows read, none dropped")
        return
    parts = ", ".join(
        f"{n:,} {reason.replace('_', ' ')}" for reason, n in report.dropped.items() if n
    )
    info(
        f"{name}: {report.total:,} rows read, {report.kept:,} kept, "
        f"{report.n_dropped:,} dropped ({parts}); --strict makes these errors"
    )


def print_day_scope(scope: Any, cfg: Any, label: str = "") -> None:
    """Say how many of the day's orders are planned and what the study area and the
    service hours left out (docs/method.md §1), from its ``sim.days.DayScope``;
    ``label`` names the hub of a city run."""
    left = []
    if scope.outside_area:
        left.append(f"{scope.outside_area:,} outside the {cfg.data.size_km:g} km study area")
    if scope.outside_hours:
        left.append(
            f"{scope.outside_hours:,} due outside service hours "
            f"{cfg.data.service_start}-{cfg.data.service_end}"
        )
    tail = f", {sum((scope.outside_area, scope.outside_hours)):,} left out ({'; '.join(left)})"
    info(
        f"{label}{scope.day.isoformat()}: {scope.orders_due:,} orders due, "
        f"{scope.planned:,} planned" + (tail if left else "")
    )


UNDELIVERED_WARN = 0.10


def warn_undelivered(metrics: dict[str, Any], drones: int) -> None:
    """Warn when more than 10 % of a day's requests stayed undelivered, and about
    requests no drone can serve at all (too heavy, too far)."""
    heavy, far = metrics.get("unservable_heavy", 0), metrics.get("unservable_far", 0)
    if heavy or far:
        warn(
            f"{metrics['day']}: {heavy:,} parcels heavier than the payload limit and {far:,} "
            "requests beyond any drone's reach from the nearest depot cannot be served"
        )
    share = metrics["undelivered"] / max(metrics["requests"], 1)
    if share > UNDELIVERED_WARN:
        warn(
            f"{metrics['day']}: {metrics['undelivered']:,} of {metrics['requests']:,} "
            f"requests ({share:.0%}) stayed undelivered with {drones} "
            + ("drone" if drones == 1 else "drones")
        )


def kv_table(title: str, rows: list[tuple[str, str]]) -> Table:
    t = table(title, show_header=False)
    t.add_column("key", style="bold")
    t.add_column("value")
    for k, v in rows:
        t.add_row(k, v)
    return t


def is_terminal() -> bool:
    return sys.stderr.isatty()
