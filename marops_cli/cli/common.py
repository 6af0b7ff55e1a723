"""Shared CLI plumbing: error handling, consoles, option parsing helpers.

``require_input`` and ``protect_inputs`` live in the application layer
(marops_cli/app/inputs.py); they are imported here for the commands that use them."""

from __future__ import annotations

import functools
import json
import os
import re
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn, TypeVar

import typer
from rich.console import Console
from rich.table import Table

from ..app.inputs import protect_inputs, require_input
from ..errors import InputError, MaropsError, bad_path
from ..io.ownership import allow_replacing_foreign, register_stdin

__all__ = [
    "PLAIN",
    "STATE",
    "begin",
    "console",
    "emit_json",
    "error_json",
    "guarded",
    "info",
    "is_terminal",
    "kv_table",
    "out",
    "protect_inputs",
    "require_input",
    "set_output",
    "show_table",
    "stopped",
    "table",
    "warn",
]


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
# Messages and tables quote file names and what files hold: rich markup and emoji codes
# are off, so ``[red]`` or ``:bomb:`` in a name is printed as it is (and ``[/]`` is no
# MarkupError after the run's files are written).


def _console(stderr: bool) -> Console:
    width = _WIDE if PLAIN else None
    return Console(
        stderr=stderr,
        width=width,
        soft_wrap=PLAIN,
        no_color=PLAIN,
        highlight=False,
        markup=False,
        emoji=False,
    )


console = _console(stderr=True)
"""Messages and progress (stderr)."""
out = _console(stderr=False)
"""Result tables (stdout), so a cron job's log keeps them whole."""
STATE: dict[str, bool] = {"debug": False, "quiet": False, "json": False, "stopped": False}
"""``stopped``: the run said it was interrupted or terminated (:func:`say_stopped`)."""


def set_output(quiet: bool = False, as_json: bool = False) -> None:
    """Apply a command's ``--quiet`` and ``--json`` (every invocation sets both)."""
    STATE["quiet"], STATE["json"] = bool(quiet), bool(as_json)


def begin(data: Path, *, quiet: bool, as_json: bool, force: bool) -> Path:
    """A command's first steps: its ``--quiet`` and ``--json``, whether it may replace
    files marops did not write (``--force``), and its data, which must exist. Returns
    the data file to read: ``data``, or for ``-`` what came on standard input."""
    set_output(quiet, as_json)
    allow_replacing_foreign(force)
    if str(data) == STDIN:
        data = stdin_file()
    require_input(data)
    return data


STDIN = "-"
"""The data path that means standard input."""


_stdin_copy: Path | None = None


def _error_line(exc: BaseException) -> str:
    """The one line of an error: standard input's copy named as standard input, and a
    line break inside (a file name may hold one) written as ``\\n``."""
    text = str(exc)
    if _stdin_copy is not None:
        text = text.replace(str(_stdin_copy), "standard input (-)")
    return one_line(text)


MAX_STDIN = 2 << 30
"""Bytes marops copies from standard input: above any city's LaDe export, and a pipe
that never ends is refused at this size instead of filling the temporary disk."""


_STDIN_FOLDER = "marops-stdin-"
"""Start of the name of the temporary folder of standard input's copy: the folder is
``marops-stdin-PID-XXXXXXXX``, PID the run's process id (:func:`_sweep_stdin_copies`)."""
_STDIN_MARK = ".marops-stdin"
"""The file in that folder that says marops made it: it holds ``marops-stdin PID``."""


def stdin_file() -> Path:
    """Standard input copied into a file of its own (``stdin``, in a temporary folder
    removed when marops exits), so it is read as a file is: CSV, CSV.gz or Parquet told
    by its first bytes, hashed for the depots cache, read again by worker processes.
    More than :data:`MAX_STDIN` bytes is an error, and the copy is removed at once. The
    copies that killed runs left behind (kill -9 leaves no time to remove one) are
    removed first (:func:`_sweep_stdin_copies`). A regular file on standard input
    (``< FILE``) is an input of the run: no output may replace it."""
    import atexit
    import shutil
    import tempfile

    if sys.stdin is None or sys.stdin.isatty():
        what = "closed" if sys.stdin is None else "a terminal"
        raise InputError(
            f"DATA - reads the LaDe export from standard input, which is {what}; "
            "pipe it in (marops CMD - … < lade.csv)"
        )
    register_stdin()
    global _stdin_copy
    _sweep_stdin_copies(Path(tempfile.gettempdir()))
    folder = Path(tempfile.mkdtemp(prefix=f"{_STDIN_FOLDER}{os.getpid()}-"))
    atexit.register(shutil.rmtree, folder, True)
    (folder / _STDIN_MARK).write_text(f"marops-stdin {os.getpid()}\n", encoding="ascii")
    path = folder / "stdin"
    _stdin_copy = path  # errors name "standard input", not this file
    try:
        size = _copy_stdin(path)
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)  # nothing half-copied stays behind
        raise
    if size == 0:
        raise InputError("DATA - reads standard input, and it is empty")
    return path


def _sweep_stdin_copies(temp: Path) -> None:
    """Remove from ``temp`` the copies of standard input that runs of marops left when
    killed: a folder ``marops-stdin-PID-XXXXXXXX`` of this user whose process PID has
    ended, holding marops' mark (:data:`_STDIN_MARK`, naming that PID) and at most the
    file ``stdin`` beside it. Anything else is left as it is: another user's folder, a
    running process's, one without the mark (a folder someone made by that name), one
    holding other files, a link. Where a process id cannot be asked after (not POSIX),
    nothing is removed."""
    import re
    import stat

    if os.name != "posix":
        return
    pattern = re.compile(re.escape(_STDIN_FOLDER) + r"([0-9]+)-[A-Za-z0-9_]+")
    try:
        entries = list(os.scandir(temp))
    except OSError:
        return
    for entry in entries:
        found = pattern.fullmatch(entry.name)
        if found is None or int(found[1]) == os.getpid() or _running(int(found[1])):
            continue
        try:
            st = entry.stat(follow_symlinks=False)
            if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.getuid():
                continue
            inside = list(os.scandir(entry.path))
            names = {_STDIN_MARK, "stdin"}
            if any(e.name not in names or not e.is_file(follow_symlinks=False) for e in inside):
                continue
            mark = Path(entry.path, _STDIN_MARK)  # missing: OSError below, left as it is
            if (
                mark.stat().st_size > 64
                or mark.read_bytes() != b"marops-stdin %s\n" % found[1].encode()
            ):
                continue
            for e in inside:
                os.unlink(e.path)
            os.rmdir(entry.path)
        except OSError:
            continue  # removed meanwhile by another run, or not ours to remove


def _running(pid: int) -> bool:
    """Whether a process of id ``pid`` runs (one of another user's counts as running)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True
    return True


def _copy_stdin(path: Path) -> int:
    """Copy standard input into ``path``; its size, at most :data:`MAX_STDIN`."""
    size = 0
    source = sys.stdin.buffer
    try:
        with path.open("wb") as fh:
            while block := source.read(1 << 20):
                size += len(block)
                if size > MAX_STDIN:
                    raise InputError(
                        f"more than {MAX_STDIN / 2**30:g} GiB came on it, the most marops copies "
                        "from a pipe; save the data to a file and pass its path",
                        file="standard input (-)",
                    )
                fh.write(block)
    except OSError as exc:  # a full temporary disk, most likely
        raise InputError(
            f"standard input could not be copied to a temporary file ({exc.strerror or exc}); "
            "save it to a file and pass its path"
        ) from exc
    return size


def info(message: str) -> None:
    """A progress or status line on stderr; silent with ``--quiet`` or ``--json``. One
    line: a line break inside (a file name may hold one) is written as ``\\n``."""
    if not (STATE["quiet"] or STATE["json"]):
        console.print(one_line(message))


_CONTROL = re.compile("[\x00-\x08\x0a-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e\u2066-\u2069]")
"""Characters a terminal acts on rather than shows (all control characters but tab: ESC
starts a sequence that clears the screen or recolours what follows; the line and
paragraph separators; the bidirectional overrides, which reorder what follows)."""
_NAMED = {"\r": "\\r", "\n": "\\n"}


def one_line(text: str) -> str:
    """``text`` on one line, as a terminal shows it: carriage returns and line breaks
    written as ``\\r``, ``\\n``, other control characters (a file name or a cell may hold
    any) as ``\\x1b``, ``\\u202e``."""
    return _CONTROL.sub(_escaped, text)


def _escaped(m: re.Match[str]) -> str:
    c = m[0]
    return _NAMED.get(c) or (f"\\x{ord(c):02x}" if ord(c) < 0x100 else f"\\u{ord(c):04x}")


def warn(message: str) -> None:
    """A warning on stderr (shown with ``--quiet`` and ``--json`` too)."""
    console.print(one_line(f"warning: {message}"))


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


def show_table(t: Table, keys: int = 1) -> None:
    """Print a result table on stdout unless ``--json`` replaces it or ``--quiet`` asks
    for warnings and errors only (the results are in the files written). On a terminal
    it fits the width with every cell whole: the columns that do not fit beside the
    first ``keys`` (which name a row) go on to further tables (marops_cli/cli/fit.py)."""
    if STATE["json"] or STATE["quiet"]:
        return
    if PLAIN:  # a log keeps lines whole however long
        out.print(t)
        return
    from .fit import fit_table

    for part in fit_table(t, out.width, keys):
        out.print(part)


F = TypeVar("F", bound=Callable[..., Any])


def guarded(fn: F) -> F:
    """Turn library errors into one line on stderr and the exit code of docs/outputs.md
    (with ``--json``, and one JSON document on stdout: :func:`_fail`). ``fn`` is a
    command's function, ``NAME_command``."""
    command = fn.__name__.removesuffix("_command").replace("_", "-")

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except MaropsError as exc:
            if STATE["debug"]:
                raise
            exc = _blame_setting(exc, kwargs)
            if isinstance(exc, InputError):
                _name_env_vars(exc)
            _fail(_error_line(exc), exc.exit_code, command, kwargs)
        except OSError as exc:
            if STATE["debug"]:
                raise
            # A path the system cannot even look up is bad usage; other failures are the run's.
            bad = bad_path(exc)
            _fail(_error_line(bad or exc), 1 if bad is None else 2, command, kwargs)
        except MemoryError:
            if STATE["debug"]:
                raise
            # What was being written is removed on the way out (an output set's
            # temporaries); a run the system kills for memory never gets here.
            text = (
                f"out of memory during {command}: ask for less at once (fewer days, a "
                "smaller file or fleet) or run it on a machine with more memory"
            )
            _fail(text, 1, command, kwargs)
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM (Terminated)
            # A use case interrupted after some of its work was written says what it
            # keeps in the exception's notes (marops_cli/app/replay_areas.py).
            stopped(exc, "; ".join(getattr(exc, "__notes__", ())), command)
        except typer.Exit:  # the command's own end, a stop it reported included
            raise
        except Exception:
            # SIGTERM or Ctrl-C inside a library's import (pandas's, loaded lazily by
            # pyarrow, which swallows the interruption) leaves that module half made,
            # and the next use fails with some other error: the run was stopped all
            # the same, and says so in one line.
            signalled = stop_signal()
            if signalled is not None and not STATE["debug"]:
                stopped(signalled, "", command)
            raise

    return wrapper  # type: ignore[return-value]


def _fail(text: str, code: int, command: str, options: dict[str, Any]) -> NoReturn:
    """End ``command`` with ``marops: error: TEXT`` on stderr and exit ``code``; with
    ``--json`` (``options["as_json"]``, also when the error came before the command
    applied it) also the error as one JSON document on stdout (:func:`error_json`)."""
    typer.echo(f"marops: error: {one_line(text)}", err=True)
    if STATE["json"] or options.get("as_json") is True:
        error_json(command, text, code)
    raise typer.Exit(code) from None


def error_json(command: str, text: str, code: int) -> None:
    """A failed run's JSON document on stdout (docs/outputs.md): the command, the error
    line without its ``marops: error:`` prefix, and the exit code."""
    emit_json({"command": command, "error": text, "exit_code": code})


def _name_env_vars(exc: InputError) -> None:
    """An option whose value came from its environment variable is named with it, the
    first time, as click names one it cannot parse: ``invalid option --drones (env var:
    'MAROPS_DRONES'): …``; the user gave no ``--drones``."""
    from ..errors import flag
    from .usage import env_sourced, invoked

    ctx = invoked()
    from_env = env_sourced(ctx) if ctx is not None else {}
    if not from_env:
        return
    named: set[str] = set()

    def spell(name: str, on: bool) -> str:
        text = flag(name, on)
        if on or text not in from_env or text in named:  # a switch asked for: no value
            return text
        named.add(text)
        return f"{text} (env var: '{from_env[text]}')"

    exc.respell(spell)


def _blame_setting(exc: MaropsError, options: dict[str, Any]) -> MaropsError:
    """A setting the data cannot meet names the config file that set it, unless the
    command's option of that name did (docs/config.md)."""
    from ..config import sets_key
    from ..errors import SettingError

    if not isinstance(exc, SettingError) or exc.file is not None:
        return exc
    config = options.get("config")
    if options.get(exc.key.split(".")[-1]) is None and config and sets_key(config, exc.key):
        return SettingError(exc.message, key=exc.key, file=config)
    return exc


INTERRUPTED = threading.Event()
"""Set when Ctrl-C (SIGINT) arrived (marops_cli/cli/app.py)."""


def stop_signal() -> KeyboardInterrupt | None:
    """What stopped the run when SIGTERM or Ctrl-C has arrived (even if a library
    swallowed the exception it raised), else None."""
    from ..io.atomic import TERM_RECEIVED, Terminated

    if TERM_RECEIVED.is_set():
        return Terminated()
    return KeyboardInterrupt() if INTERRUPTED.is_set() else None


def say_stopped(exc: KeyboardInterrupt, kept: str = "") -> tuple[str, int]:
    """Ctrl-C or SIGTERM (:class:`~marops_cli.io.atomic.Terminated`): its one line on
    stderr, with what the run keeps when it says; (that line, the exit code: 130, 143 for
    SIGTERM)."""
    from ..io.atomic import Terminated

    term = isinstance(exc, Terminated)
    how = "terminated" if term else "interrupted"
    line = f"{how}; {kept}" if kept else how
    typer.echo(f"marops: {line}", err=True)
    STATE["stopped"] = True
    return line, 143 if term else 130


def stopped(exc: KeyboardInterrupt, kept: str = "", command: str | None = None) -> NoReturn:
    """Ctrl-C or SIGTERM: its line (:func:`say_stopped`) and its exit; with ``--json``
    also ``command``'s JSON error document (:func:`error_json`)."""
    line, code = say_stopped(exc, kept)
    if STATE["json"] and command is not None:
        error_json(command, line, code)
    raise typer.Exit(code) from None


def kv_table(title: str, rows: list[tuple[str, str]]) -> Table:
    t = table(title, show_header=False)
    t.add_column("key", style="bold")
    t.add_column("value")
    for k, v in rows:
        t.add_row(k, v)
    return t


def is_terminal() -> bool:
    return sys.stderr.isatty()
