"""Reading the small JSON and TOML files marops takes as input (config, depots, fleet,
policy sidecar)."""

from __future__ import annotations

import errno
import json
import math
import os
import stat
import sys
from pathlib import Path
from typing import Any, Literal

from ..errors import InputError, not_found

MAX_SMALL_FILE = 64 << 20
"""Bytes a small input (JSON or TOML: depots, fleet, config, sidecars, marops' own
records) may have: far above any real one, and a device or a huge file is refused before
it fills the memory."""


def read_small_text(path: str | Path, what: str, limit: int | None = None) -> str:
    """The UTF-8 text of the small input ``path`` (:func:`read_text_at_most`): an
    :class:`InputError` naming it when it is larger than :data:`MAX_SMALL_FILE` (or
    ``limit`` bytes, when smaller: a depots or hubs file's own cap)."""
    cap = MAX_SMALL_FILE if limit is None else min(limit, MAX_SMALL_FILE)
    return read_text_at_most(path, what, cap)


def read_text_at_most(path: str | Path, what: str, cap: int) -> str:
    """The UTF-8 text of ``path`` (a leading byte-order mark dropped, as some editors
    write one): an :class:`InputError` naming it when it is larger than ``cap`` bytes,
    found by reading one byte past the cap, never the whole of a device or a huge file;
    OS and decoding errors propagate."""
    p = Path(path)
    # A named pipe nobody writes to would block a plain open for ever; opened without
    # blocking, it reads as empty, while a pipe with a writer (``<(...)``) reads whole.
    fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK)
    try:
        regular = stat.S_ISREG(os.fstat(fd).st_mode)
        os.set_blocking(fd, True)
        f = os.fdopen(fd, "rb")  # a folder is refused here (IsADirectoryError)
    except OSError:
        os.close(fd)
        raise
    with f:
        data = f.read(cap + 1)
    if len(data) > cap:
        raise InputError(f"{what} is larger than {cap >> 20} MiB", file=p)
    if not data and not regular:
        raise InputError(f"{what} is a pipe or a device that gave nothing to read", file=p)
    return data.decode("utf-8-sig")


def parse_json(text: str | bytes) -> Any:
    """``json.loads``; a key given twice in an object, and a document nested too deeply
    for the parser, are a ``ValueError`` as any malformed document is (numbers too long
    to convert already are: :func:`_long_number`)."""
    try:
        return json.loads(text, object_pairs_hook=_unique_keys)
    except RecursionError:
        raise ValueError("nested too deeply") from None
    except ValueError as exc:
        raise _long_number(exc) from None


def parse_json_at(text: str, pos: int) -> Any:
    """The JSON value that starts at ``pos`` of ``text``, whatever follows it, checked as
    :func:`parse_json` checks a document (a key given twice, too deep a nesting)."""
    try:
        return json.JSONDecoder(object_pairs_hook=_unique_keys).raw_decode(text, pos)[0]
    except RecursionError:
        raise ValueError("nested too deeply") from None
    except ValueError as exc:
        raise _long_number(exc) from None


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object as a dict; a key given twice in it is a ``ValueError``, as TOML's
    parser has it (``json`` would keep the last value unsaid)."""
    doc: dict[str, Any] = {}
    for key, value in pairs:
        if key in doc:
            raise ValueError(f"the key {key!r} appears twice in one object")
        doc[key] = value
    return doc


def parse_toml(text: str) -> dict[str, Any]:
    """``tomllib.loads``; a document nested too deeply is a ``ValueError`` as any
    malformed one is (``TOMLDecodeError`` is one)."""
    import tomllib

    try:
        return tomllib.loads(text)
    except RecursionError:
        raise ValueError("nested too deeply") from None
    except ValueError as exc:
        raise _long_number(exc) from None


def _long_number(exc: ValueError) -> ValueError:
    """``exc``; for a whole number longer than Python converts, what the file holds
    (``a number of 5001 digits, ...``) rather than advice to call a Python function."""
    import re

    found = re.search(r"integer string conversion.*?value has (\d+) digits", str(exc))
    if found is None:
        return exc
    limit = sys.get_int_max_str_digits()
    return ValueError(f"a number of {found.group(1)} digits, more than the {limit} read")


def read_document(
    path: str | Path,
    what: str,
    kind: Literal["json", "toml"] | None = None,
    limit: int | None = None,
    *,
    cap: int | None = None,
) -> Any:
    """The parsed JSON or TOML document ``path`` (``kind`` None: TOML for a ``.toml``
    name, else JSON); a missing, unreadable or malformed file, or one larger than
    ``limit`` bytes (:func:`read_small_text`), is an :class:`InputError` naming it as
    ``what`` ("fleet file"). ``cap``: the bytes it may have in place of the small-file
    caps (a route file's, above them: :data:`marops_cli.io.routejson.MAX_ROUTE_JSON`)."""
    p = Path(path)
    kind = kind or ("toml" if p.suffix.lower() == ".toml" else "json")
    name = kind.upper()
    try:
        text = read_small_text(p, what, limit) if cap is None else read_text_at_most(p, what, cap)
        return parse_toml(text) if kind == "toml" else parse_json(text)
    except IsADirectoryError as exc:
        raise InputError(f"{what} is a folder, expected a {name} file", file=p) from exc
    except OSError as exc:
        if isinstance(exc, FileNotFoundError) or exc.errno == errno.ELOOP:
            raise not_found(p, what) from exc
        raise InputError(f"cannot read the {what} ({exc.strerror})", file=p) from exc
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"{what} is not valid {name} ({first_line(exc)})", file=p) from exc


def read_json(path: str | Path, what: str, limit: int | None = None) -> Any:
    """The parsed JSON document (:func:`read_document`)."""
    return read_document(path, what, "json", limit)


def first_line(exc: BaseException) -> str:
    """The first line of an error's message (at most 200 characters), for a one-line
    error."""
    text = str(exc).strip()
    return text.splitlines()[0][:200] if text else type(exc).__name__


def json_number(value: Any, path: str | Path, column: str, *, whole: bool = False) -> float:
    """``value`` from a JSON or TOML input as a finite number (``whole``: a whole one);
    anything else (text, NaN, infinity) is an :class:`InputError` naming the file and the
    key."""
    kind = "whole number" if whole else "number"
    ok = isinstance(value, int | float) and not isinstance(value, bool)
    if not ok or not math.isfinite(value) or (whole and int(value) != value):
        raise InputError(f"expected a {kind}, got {value!r}", file=path, column=column)
    return float(value)


def refuse_unknown_keys(
    doc: dict[str, Any],
    known: frozenset[str] | set[str],
    where: str,
    file: str | Path,
    at: str = "",
    listed: bool = False,
) -> None:
    """One line naming the first key of ``doc`` (a table of a JSON file) not in
    ``known``: ``unknown key 'x' {where}`` (``listed``: and the keys expected), its key
    path ``at`` + the key; a typo such as ``x-m`` must not read as a missing value."""
    unknown = sorted(set(doc) - set(known))
    if unknown:
        expected = f" (expected some of: {', '.join(sorted(known))})" if listed else ""
        raise InputError(
            f"unknown key {unknown[0]!r} {where}{expected}", file=file, column=f"{at}{unknown[0]}"
        )


def refuse_misspelt_keys(doc: dict[str, Any], read: tuple[str, ...], file: str | Path) -> None:
    """One line naming the first key of ``doc`` (a file whose other keys are kept as
    they are, an actor's sidecar) that reads as a misspelling of a key in ``read`` that
    ``doc`` lacks (``operating-model``): a typo must not read as a missing value."""
    import difflib

    for key in doc:
        if key in read or not isinstance(key, str):
            continue
        close = difflib.get_close_matches(key, read, n=1, cutoff=0.75)
        if close and close[0] not in doc:
            raise InputError(
                f"unknown key {key!r} (did you mean {close[0]}?)", file=file, column=key
            )
