"""``report.html``: one interactive page per output folder of a run (docs/report.md),
built from the files the run wrote there, so that ``--report`` and ``marops report DIR``
give the same page; the pages of a report of several share one plotly.js. Needs plotly
(``pip install 'marops[report]'``), imported only when a report is made."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeGuard

from ..data.jsonfile import first_line
from ..errors import InputError
from .folder import (
    REPORT,
    is_evaluation,
    metrics,
    one_run,
    route_files,
    route_files_exist,
    sub_reports,
    unfinished_parts,
)
from .page import EXTRA, Page, require_plotly, script_bytes, script_name

if TYPE_CHECKING:
    from ..io import OutputSet
    from ..segment.depots import Depots

__all__ = [
    "EXTRA",
    "REPORT",
    "report_folders",
    "report_page",
    "require_plotly",
    "shared_script",
    "write_reports",
]


def report_page(folder: Path, depots: Depots | None = None) -> Page | None:
    """The page of one folder: an evaluation, a day or window (its routes), or a
    several-day or city run (its top-level ``metrics.json``); None for anything else.
    ``depots``: the study area's depots, for the service areas and every depot."""
    if is_evaluation(folder):
        from .evaluation import evaluation_page

        return evaluation_page(folder)
    files = route_files(folder)
    doc = metrics(folder)
    if files is not None and doc is not None:
        one_run(folder / "metrics.json", doc.get("meta"), files.meta)
    if files is not None:
        from .day import day_page

        return day_page(files, doc, depots)
    if _over_several(doc):
        from .checks import reading
        from .index import index_page

        with reading(folder / "metrics.json"):
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
    if not _has_page(folder):
        # A run stopped before its metrics.json over the days: the days it finished.
        return _below(unfinished_parts(folder) if below and not is_evaluation(folder) else [])
    several = not is_evaluation(folder) and not route_files_exist(folder)
    return [*_below(sub_reports(folder) if below and several else []), folder]


def _below(subs: list[Path]) -> list[Path]:
    """The folders below ``subs`` (day and hub folders) that get a page, theirs included."""
    found: list[Path] = []
    for sub in subs:
        below_sub = report_folders(sub)
        if below_sub and sub.is_symlink():  # its pages would go through it, elsewhere
            raise InputError(
                "is a link to a day's or hub's outputs; the report writes pages only "
                "into the run's own folders: remove the link, or report on its target",
                file=sub,
            )
        found += below_sub
    return found


def shared_script(folder: Path, folders: list[Path]) -> Path | None:
    """The plotly.js that the pages of a report of ``folder`` over ``folders`` (its
    :func:`report_folders`) load: one file in ``folder`` where the report makes several
    pages, none (each page inlines it, and opens on its own) for a single page."""
    return folder / script_name() if len(folders) > 1 else None


def _script_src(page_folder: Path, script: Path) -> str:
    """The shared plotly.js as the page in ``page_folder`` names it: ``../`` for each
    folder between them (never a folder's name, which may hold anything)."""
    depth = len(page_folder.relative_to(script.parent).parts)
    return "../" * depth + script.name


def _script_set(script: Path) -> OutputSet | None:
    """The shared plotly.js to put in place, or None where the file is marops's with
    these bytes already (a city's hubs each write their pages with it; a re-run). A file
    of that name marops did not write is refused (``--force`` replaces it)."""
    from ..data.reader import sha256_file
    from ..io import OutputSet
    from ..io.ownership import written_by_marops

    data = script_bytes()
    if script.is_file() and not script.is_symlink() and written_by_marops(script):
        import hashlib

        if sha256_file(script) == hashlib.sha256(data).hexdigest():
            return None
    files = OutputSet()
    try:
        files.write_bytes(script, data)
    except BaseException:
        files.discard()
        raise
    return files


def _link_up(page: Page, folder: Path, folders: list[Path], shared: Path | None) -> None:
    """A day's or hub's page links the page of the run above it (a hub's, a city's or a
    several-day run's), where that page is made in the same run: among ``folders``, or
    the city's (``shared``), whose page a city run writes once its hubs' are done."""
    from urllib.parse import quote

    for up, rel in ((folder.parent, "../"), (folder.parent.parent, "../../")):
        if up in folders or (up == shared and folder != shared):
            page.up(quote(rel + REPORT), f"the run's page ({up.name or up})")
            return


def write_reports(
    folder: Path,
    depots: Depots | None = None,
    *,
    below: bool = True,
    on_page: Callable[[int, int, Path], None] | None = None,
    folders: list[Path] | None = None,
    shared: Path | None = None,
) -> list[Path]:
    """Write ``report.html`` into ``folder`` (and, with ``below``, into its day and hub
    folders); the files written. ``on_page(k, n, path)`` is told as the k-th of the ``n``
    pages to make is done (a city's month holds hundreds). ``folders``: the
    :func:`report_folders` of ``folder`` where the caller has them already. ``shared``:
    the folder above whose plotly.js the pages load (a city's, for a hub's pages);
    by default :func:`shared_script`'s."""
    from ..io import OutputSet

    written: list[Path] = []
    folders = report_folders(folder, below=below) if folders is None else folders
    script = shared / script_name() if shared is not None else shared_script(folder, folders)
    # Every page is made before any is put in place: a folder that cannot be reported on
    # (a damaged day among thirty) leaves every page as it was. Each folder's page is a
    # set of its own, put in place one after the other (one set over a city's month
    # would hold every folder open at once).
    # The shared plotly.js is put in place first, with the pages (none where one of them
    # cannot be made), so no page in place lacks it.
    pages: list[OutputSet] = []
    needs_script = False
    try:
        for k, f in enumerate(folders, start=1):
            try:
                page = report_page(f, depots)
            except (TypeError, ValueError, KeyError, AttributeError, IndexError) as exc:
                # Files that read, but hold what no marops run writes (a column of another
                # type, a key gone) that the checks of each file the page reads missed
                # (.checks: those name the file, and the row and column or key): edited
                # since, or not marops's.
                why = first_line(exc)
                raise InputError(
                    f"holds outputs marops cannot report on, edited or not marops's ({why})",
                    file=f,
                ) from exc
            if page is not None:
                _link_up(page, f, folders, shared)
                files = OutputSet()
                pages.append(files)
                # A folder name that is not UTF-8 (Linux allows any bytes) is shown
                # escaped, as marops's JSON outputs write it.
                src = _script_src(f, script) if script is not None else None
                text = page.html(src)
                files.write_bytes(f / REPORT, text.encode("utf-8", "backslashreplace"))
                written.append(f / REPORT)
                needs_script = needs_script or (src is not None and page.has_figures)
            if on_page is not None:  # the page, or the folder that had none to write
                on_page(k, len(folders), f / REPORT if page is not None else f)
        if needs_script and script is not None:
            script_files = _script_set(script)
            if script_files is not None:
                pages.insert(0, script_files)
                written.insert(0, script)
        while pages:
            pages[0].commit()
            pages.pop(0)
    finally:
        for files in pages:  # those not in place: their temporaries
            files.discard()
    return written
