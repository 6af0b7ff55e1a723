"""``report.html`` of a run's output folder (docs/report.md): for ``--report`` at the end
of a run, and for ``marops report DIR`` on a folder an earlier run wrote."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import InputError, naming, not_found, option
from .inputs import DEPOTS_IN_MEMORY, DepotsInput, given_depots
from .progress import SILENT, Progress

if TYPE_CHECKING:
    from ..segment.depots import Depots

__all__ = ["check_report", "make_report", "report_outputs", "write_pages"]


def check_report(wanted: bool) -> None:
    """``--report`` needs plotly: one line naming the extra (exit 2) before any work."""
    if wanted:
        from ..report import require_plotly

        require_plotly()


def report_outputs(folder: Path, folders: list[Path]) -> list[Path]:
    """The ``report.html`` of each of ``folders`` (the report of ``folder``), and the
    plotly.js they share where there are several: outputs to check before the work."""
    from ..report import REPORT, shared_script

    script = shared_script(folder, folders)
    return [f / REPORT for f in folders] + ([script] if script is not None else [])


def write_pages(
    folder: Path,
    depots: Depots | None = None,
    progress: Progress = SILENT,
    folders: list[Path] | None = None,
    shared: Path | None = None,
) -> list[Path]:
    """``report.html`` into ``folder`` and its day and hub folders (``folders``: its
    :func:`~marops_cli.report.report_folders`, where the caller has them already), a
    progress step per page where there are several (a city's month holds hundreds);
    the files written. ``shared``: the folder above whose plotly.js the pages load (a
    city's, for a hub's pages)."""
    from ..report import report_folders, write_reports

    folders = report_folders(folder) if folders is None else folders
    if len(folders) < 2:
        return write_reports(folder, depots, folders=folders, shared=shared)

    def on_page(k: int, n: int, path: Path) -> None:
        progress.advance(f"report {k}/{n}: {path}")

    progress.start("report", len(folders), "pages")
    try:
        return write_reports(folder, depots, on_page=on_page, folders=folders, shared=shared)
    finally:
        progress.finish()


def make_report(
    folder: str | Path, *, depots: DepotsInput | None = None, progress: Progress = SILENT
) -> list[Path]:
    """Write ``report.html`` into an output folder of an earlier run (and into each of its
    day and hub folders); ``depots``: the run's depots (its file, or in memory), for the
    service areas and the depots no route used. The files written."""
    from ..io import folder_lock
    from ..io.ownership import check_outputs, register_inputs
    from ..report import report_folders, require_plotly

    folder = Path(folder)
    if not folder.exists():
        raise not_found(folder, "folder")
    if not folder.is_dir():
        raise InputError(
            f"is not a folder (the {option('out')} of replay-day, plan-window or evaluate)",
            file=folder,
        )
    from ..io.atomic import check_free

    check_free(folder)  # a run still writing there: said as such, not as nothing to report
    require_plotly()
    targets = report_folders(folder)
    if not targets:
        raise _nothing_to_report(folder)
    register_inputs([depots])
    check_outputs(report_outputs(folder, targets))
    if folder not in targets:  # a several-day or city run stopped before its summary
        progress.warning(_unfinished(folder, targets))
    loaded = _depots(depots)
    with folder_lock(folder):
        try:
            written = write_pages(folder, loaded, progress, targets)
        except InputError as exc:
            if depots is not None and exc.column in ("frame", "depot"):  # another run's
                named = Path(depots) if isinstance(depots, str | Path) else DEPOTS_IN_MEMORY
                raise naming(exc, named) from None
            raise
    if not written:  # a metrics.json of no day, no several days and no city
        raise _nothing_to_report(folder)
    return written


def _unfinished(folder: Path, targets: list[Path]) -> str:
    """The line that says ``folder``'s run did not finish, and what is reported of it."""
    from ..config import count

    parts = list(dict.fromkeys(t.relative_to(folder).parts[0] for t in targets))
    shown = ", ".join(parts) if len(parts) <= 3 else f"{parts[0]} … {parts[-1]}"
    hubs = sum(p.startswith("hub-") for p in parts)
    kind = "hub" if hubs == len(parts) else "day" if not hubs else "day or hub"
    return (
        f"{folder} holds no metrics.json over its {kind}s: its run did not finish (which "
        f"{kind}s it was to replay is not recorded); reporting the {count(len(parts), kind)} "
        f"there ({shown}); the same replay-day again finishes it, keeping these"
    )


def _nothing_to_report(folder: Path) -> InputError:
    return InputError(
        "holds no marops outputs to report on (routes, metrics.json or an evaluation's "
        "summary.csv and results.parquet)",
        file=folder,
    )


def _depots(depots: DepotsInput | None) -> Depots | None:
    if depots is None:
        return None
    from ..segment.depots import Depots

    given = given_depots(depots)
    return given if isinstance(given, Depots) else Depots.load(given)
