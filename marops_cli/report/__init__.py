"""``report.html``: one self-contained, interactive page per output folder of a run
(docs/report.md), built from the files the run wrote there, so that ``--report`` and
``marops report DIR`` give the same page. Needs plotly (``pip install 'marops[report]'``),
imported only when a report is made."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeGuard

from ..data.jsonfile import first_line
from ..errors import InputError
from .folder import REPORT, is_evaluation, metrics, route_files, route_files_exist, sub_reports
from .page import EXTRA, Page, require_plotly

if TYPE_CHECKING:
    from ..segment.depots import Depots

__all__ = ["EXTRA", "REPORT", "report_folders", "report_page", "require_plotly", "write_reports"]


def report_page(folder: Path, depots: Depots | None = None) -> Page | None:
    """The page of one folder: an evaluation, a day or window (its routes), or a
    several-day or city run (its top-level ``metrics.json``); None for anything else.
    ``depots``: the study area's depots, for the service areas and every depot."""
    if is_evaluation(folder):
        from .evaluation import evaluation_page

        return evaluation_page(folder)
    files = route_files(folder)
    doc = metrics(folder)
    if files is not None:
        from .day import day_page

        return day_page(files, doc, depots)
    if _over_several(doc):
        from .index import index_page

        return index_page(folder, doc)
    return None


def _over_several(doc: object) -> TypeGuard[dict[str, Any]]:
    """A ``metrics.json`` of several days or of a city (its page links theirs)."""
    return isinstance(doc, dict) and ("total" in doc or "city" in doc)


def _has_page(folder: Path) -> bool:
    """``folder`` gets a page: an evaluation, a day or window, or several days or a city.
    A ``metrics.json`` that does not read is counted in, for its page to name it; one of
    another tool (a folder of one's own among the days) is not, so its folder is left
    alone."""
    if is_evaluation(folder) or route_files_exist(folder):
        return True
    if not (folder / "metrics.json").is_file():
        return False
    try:
        return _over_several(metrics(folder))
    except InputError:
        return True


def report_folders(folder: Path, *, below: bool = True) -> list[Path]:
    """The folders that get a ``report.html``: ``folder`` and, with ``below``, the day and
    hub folders of a several-day or city run (those first, so the top page links them)."""
    found: list[Path] = []
    if not _has_page(folder):
        return found
    several = not is_evaluation(folder) and not route_files_exist(folder)
    if below and several:
        for sub in sub_reports(folder):
            found += report_folders(sub)
    found.append(folder)
    return found


def _link_up(page: Page, folder: Path, folders: list[Path]) -> None:
    """A day's or hub's page links the page of the run above it (a hub's, a city's or a
    several-day run's), where that page is made in the same run."""
    from urllib.parse import quote

    for up, rel in ((folder.parent, "../"), (folder.parent.parent, "../../")):
        if up in folders:
            page.up(quote(rel + REPORT), f"the run's page ({up.name or up})")
            return


def write_reports(
    folder: Path,
    depots: Depots | None = None,
    *,
    below: bool = True,
    on_page: Callable[[int, int, Path], None] | None = None,
    folders: list[Path] | None = None,
) -> list[Path]:
    """Write ``report.html`` into ``folder`` (and, with ``below``, into its day and hub
    folders); the files written. ``on_page(k, n, path)`` is told as the k-th of the ``n``
    pages to make is done (a city's month holds hundreds). ``folders``: the
    :func:`report_folders` of ``folder`` where the caller has them already."""
    from ..io import OutputSet

    written = []
    folders = report_folders(folder, below=below) if folders is None else folders
    # Every page is made before any is put in place: a folder that cannot be reported on
    # (a damaged day among thirty) leaves every page as it was. Each folder's page is a
    # set of its own, put in place one after the other (one set over a city's month
    # would hold every folder open at once).
    pages: list[OutputSet] = []
    try:
        for k, f in enumerate(folders, start=1):
            try:
                page = report_page(f, depots)
            except (TypeError, ValueError, KeyError, AttributeError, IndexError) as exc:
                # Files that read, but hold what no marops run writes (a column of another
                # type, a key gone): edited since, or not marops's.
                why = first_line(exc)
                raise InputError(
                    f"holds outputs marops cannot report on, edited or not marops's ({why})",
                    file=f,
                ) from exc
            if page is not None:
                _link_up(page, f, folders)
                files = OutputSet()
                pages.append(files)
                # A folder name that is not UTF-8 (Linux allows any bytes) is shown
                # escaped, as marops's JSON outputs write it.
                files.write_bytes(f / REPORT, page.html().encode("utf-8", "backslashreplace"))
                written.append(f / REPORT)
            if on_page is not None:  # the page, or the folder that had none to write
                on_page(k, len(folders), f / REPORT if page is not None else f)
        while pages:
            pages[0].commit()
            pages.pop(0)
    finally:
        for files in pages:  # those not in place: their temporaries
            files.discard()
    return written
