"""Errors that reach the user as one line and an exit code (docs/outputs.md)."""

from __future__ import annotations

import errno
import os
import re
from collections.abc import Callable
from pathlib import Path

_KEYED = frozenset({".toml", ".json"})
"""File kinds whose places are keys: an error there names the key, not a column."""


# --- options named in messages ---------------------------------------------------------
# The same use case runs under the command line and the Python API, whose callers spell an
# option differently: ``--n-depots`` there, ``n_depots=`` here. A message names an option
# by its identity (:func:`option`, :func:`switch`); an error reads with the command line's
# flags (``str(exc)``, as the commands print it) until the API respells it with its
# keywords (:meth:`InputError.respell`).

_MARK = "\x1f"  # never in a message's own text
_MARKED = re.compile(f"{_MARK}([a-z_]+)(=?){_MARK}")

_FLAGS = {"segment_seed": "--seed", "fmt": "--format"}
"""Option identity -> its flag, where the two differ beyond ``_`` and ``-``."""
_KEYWORDS = {"segment_seed": "seed"}
"""Option identity -> the API's keyword, where the two differ (the identity of an option
is its keyword but where one keyword sets another field in another function)."""


def option(name: str) -> str:
    """Option ``name`` (``n_depots``) as an :class:`InputError`'s message names it (only
    it reads the mark): ``--n-depots`` on the command line, ``n_depots`` in the Python
    API."""
    return f"{_MARK}{name}{_MARK}"


def switch(name: str) -> str:
    """Switch ``name`` (``force``) as an :class:`InputError`'s message asks for it:
    ``--force`` on the command line, ``force=True`` in the Python API."""
    return f"{_MARK}{name}={_MARK}"


def flag(name: str, on: bool = False) -> str:
    """The command line's flag of option ``name`` (``n_depots`` -> ``--n-depots``)."""
    return _FLAGS.get(name, "--" + name.replace("_", "-"))


def keyword(name: str, on: bool = False) -> str:
    """The Python API's keyword of option ``name``; ``on``: a switch turned on
    (``force=True``)."""
    word = _KEYWORDS.get(name, name)
    return f"{word}=True" if on else word


def spelled(text: str, spell: Callable[[str, bool], str] = flag) -> str:
    """``text`` with the options it names spelled by ``spell`` (:func:`flag`, :func:`keyword`)."""
    # (a mark left alone where a bounded message was cut goes too)
    return _MARKED.sub(lambda m: spell(m[1], m[2] == "="), text).replace(_MARK, "")


# --- values quoted in messages ----------------------------------------------------------
# A message may quote what a file holds (a sidecar's operating model, a header's column
# name), and a file may hold megabytes there: every message stays a line a person reads.

MAX_QUOTED = 80
"""Characters of a file's value a message quotes (:func:`quoted`)."""
MAX_MESSAGE = 1_000
"""Characters of an :class:`InputError`'s message (its file, row and column aside); a
longer one keeps its start and end (:func:`bounded`)."""
MAX_LINE = 10_000
"""Characters of any error's whole line: the message and a path of the system's longest."""


def quoted(value: object, most: int = MAX_QUOTED) -> str:
    """``value`` as a message quotes it (its ``repr``), cut to ``most`` characters with an
    ellipsis when longer."""
    text = repr(value)
    return text if len(text) <= most else f"{text[: most - 1]}…"


def bounded(text: str, most: int = MAX_MESSAGE) -> str:
    """``text`` when at most ``most`` characters; else its start and end around an
    ellipsis that says how much was left out (what failed opens a message, what to do
    closes it)."""
    if len(text) <= most:
        return text
    head, tail = most * 2 // 3, most // 4
    return f"{text[:head]} …({len(text) - head - tail:,} characters)… {text[-tail:]}"


class MaropsError(Exception):
    """Base class: a failure the CLI reports as one line (bounded: :data:`MAX_LINE`)."""

    exit_code = 1

    def __init__(self, *args: object) -> None:
        super().__init__(*(bounded(a, MAX_LINE) if isinstance(a, str) else a for a in args))


class InputError(MaropsError):
    """Bad usage or bad input: exit code 2, the message names file, row and column.

    ``row`` is 1-based with the header as row 1, as a spreadsheet shows it.
    """

    exit_code = 2

    def __init__(
        self,
        message: str,
        *,
        file: str | Path | None = None,
        row: int | None = None,
        column: str | None = None,
    ) -> None:
        message = bounded(message)
        self.template = message
        """The message naming options by their identity (:func:`option`)."""
        self.message = spelled(message)
        self.file = str(file) if file is not None else None
        self.row = row
        self.column = bounded(column, MAX_QUOTED * 2) if isinstance(column, str) else column
        super().__init__(self.format())

    def respell(self, spell: Callable[[str, bool], str]) -> None:
        """Name the options in this error as ``spell`` spells them (:func:`keyword`: the
        Python API's), in place, so that ``raise`` keeps its traceback."""
        self.message = spelled(self.template, spell)
        self.args = (bounded(self.format(), MAX_LINE),)

    def format(self) -> str:
        where = []
        if self.file is not None:
            where.append(self.file)
        if self.row is not None:
            where.append(f"row {self.row}")
        if self.column is not None:
            where.append(f"{self._column_word()} '{self.column}'")
        prefix = ", ".join(where)
        return f"{prefix}: {self.message}" if prefix else self.message

    def _column_word(self) -> str:
        """``key`` for a place in a TOML or JSON file (a table's key, not a column)."""
        keyed = self.file is not None and Path(self.file).suffix.lower() in _KEYED
        return "key" if keyed and self.row is None else "column"


class SettingError(InputError):
    """A setting (``stage.key`` of docs/config.md) that the data cannot meet, such as more
    depots than the study area has points. The culprit is the setting, not the data: it
    names the key (as ``column``), and the command names the config file or option that
    set it (marops_cli/cli/common.py); ``{data}`` in the message becomes the data file's
    name."""

    def __init__(self, message: str, *, key: str, file: str | Path | None = None) -> None:
        super().__init__(message, file=file, column=key)

    @property
    def key(self) -> str:
        return str(self.column)

    def format(self) -> str:
        if self.file is None:
            return f"setting {self.column}: {self.message}"
        return f"{self.file}, key '{self.column}': {self.message}"


class RunError(MaropsError):
    """The run failed for a reason other than the input (exit code 1)."""

    exit_code = 1


def naming(exc: InputError, file: str | Path) -> InputError:
    """``exc`` naming ``file`` when it named no file (an error about the data's content);
    a :class:`SettingError` keeps blaming its setting and names ``file`` as the data."""
    if isinstance(exc, SettingError):
        return SettingError(exc.template.replace("{data}", Path(file).name), key=exc.key)
    if exc.file is not None:
        return exc
    return InputError(exc.template, file=file, row=exc.row, column=exc.column)


def in_hub(exc: InputError, hub: int) -> InputError:
    """``exc`` of one hub of a city run (``--hubs``) saying which hub (``hub 3: ...``),
    blaming what it blamed (a :class:`SettingError` its setting)."""
    message = f"hub {hub}: {exc.template}"
    if isinstance(exc, SettingError):
        return SettingError(message, key=exc.key, file=exc.file)
    return InputError(message, file=exc.file, row=exc.row, column=exc.column)


def not_found(path: str | Path, what: str = "file") -> InputError:
    """The error for an input ``path`` that leads to nothing (``what``: "depots file"):
    ``FILE: depots file not found``; for a loop of symbolic links ``FILE: is a loop of
    symbolic links, not a depots file``, and for a link to a missing file, where it
    points."""
    try:
        os.stat(path)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return InputError(f"is a loop of symbolic links, not a {what}", file=path)
        if os.path.islink(path):
            target = os.readlink(path)
            return InputError(
                f"{what} not found: a symbolic link to {target}, which does not exist",
                file=path,
            )
    return InputError(f"{what} not found", file=path)


def not_a_file(path: str | Path, what: str = "file") -> InputError:
    """The error for an input ``path`` that is no regular file: :func:`not_found` when it
    leads to nothing, else what it is (a folder, a pipe or a device) and what was
    expected (``what``: "policy file")."""
    if not os.path.exists(path):
        return not_found(path, what)
    if os.path.isdir(path):
        return InputError(f"is a folder, expected a {what}", file=path)
    return InputError(f"is not a regular file (a pipe or a device), expected a {what}", file=path)


BAD_PATH = (errno.ENAMETOOLONG, errno.ELOOP)
"""System errors of a path the system cannot even look up: bad usage, not a failed run."""


def bad_path(exc: OSError) -> InputError | None:
    """``exc`` as the one-line error of a path the system cannot look up (a name longer
    than the file system takes, a loop of symbolic links), naming the path:
    ``FILE: File name too long``; None for any other system error."""
    if exc.errno not in BAD_PATH:
        return None
    path = exc.filename if exc.filename is not None else exc.filename2
    message = exc.strerror or os.strerror(exc.errno)
    return InputError(message, file=os.fsdecode(path) if path is not None else None)
