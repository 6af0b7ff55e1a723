"""Models of the small files marops reads (a depots, hubs or fleet file, an actor's
sidecar, a training checkpoint) and their one-line errors (docs/decisions.md, "Files
read").

Each file's shape is a pydantic model (:class:`FileModel`): strict (``true`` is no
number, ``"3"`` no count, ``2.5`` no whole number), every number finite, unknown keys
refused (a typo must not read as a missing value), ranges as ``Field`` constraints.
:func:`validated` reads a parsed document into its model; the first thing wrong is one
:class:`~marops_cli.errors.InputError` naming the file and the key path
(``depots[3].lng``), in the words marops' messages use elsewhere (:func:`error_text`).
What a file's parts must say of each other (ids 0..n-1 each once, a depot listing itself
first) is checked by its reader after the model.
"""

from __future__ import annotations

import json
import types
import typing
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any, ClassVar, TypeVar, get_args, get_origin

from pydantic import BaseModel, BeforeValidator, ConfigDict, ValidationError
from pydantic.fields import FieldInfo

from ..errors import MAX_QUOTED, InputError, quoted

__all__ = ["FileModel", "Whole", "error_text", "file_error", "json_kind", "validated"]


class FileModel(BaseModel):
    """A table of a file marops reads. ``noun`` names it in messages (``a depot needs
    x_m``, ``unknown key 'x' in a depot``); ``shape`` says what it is where something
    else stands (``expected a depot {id, x_m, y_m, …}, got a list``); ``prefix`` opens a
    message of a key of its own that is missing or of the wrong kind (``not a marops
    depots file: ``)."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, frozen=True)

    noun: ClassVar[str] = "table"
    shape: ClassVar[str] = ""
    prefix: ClassVar[str] = ""


def _whole(value: Any) -> Any:
    """A float that is a whole number (``3.0``, as some tools write counts) as that int;
    anything else as it is, for the strict int to take or refuse."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


Whole = Annotated[int, BeforeValidator(_whole)]
"""A whole number as a file writes it: ``3`` or ``3.0``, never ``3.5``, ``"3"`` or true."""

M = TypeVar("M", bound=BaseModel)


def validated(model: type[M], doc: Any, file: str | Path, at: str = "") -> M:
    """``doc`` (a parsed JSON or TOML document, or a part of one at key path ``at``) as
    ``model``; anything else is the one-line :class:`InputError` of :func:`file_error`."""
    try:
        return model.model_validate(doc)
    except ValidationError as exc:
        raise file_error(exc, model, file, at) from None


def file_error(
    exc: ValidationError, model: type[BaseModel], file: str | Path, at: str = ""
) -> InputError:
    """``exc`` (``model`` refusing a document of ``file``) as one line naming the file and
    the key path of the first thing wrong (:func:`error_text`)."""
    key, message = error_text(exc, model, at)
    return InputError(message, file=file, column=key or None)


def error_text(exc: ValidationError, model: type[BaseModel], at: str = "") -> tuple[str, str]:
    """The key path (``at`` + ``depots[3].lng``; "" for the document itself) and the
    message of the first thing ``model`` refused: an unknown key before all else (a typo
    explains the key it misspells being missing), then the first in the file's order."""
    errors = sorted(exc.errors(), key=lambda e: e["type"] != "extra_forbidden")
    err = errors[0]
    loc = tuple(err["loc"])
    owner, field, kind = _place(model, loc)
    return _key(at, loc), _message(err, owner, field, kind)


def _key(at: str, loc: tuple[Any, ...]) -> str:
    """``at`` and ``loc`` as a key path: ``depots[3].lng``, ``types.big.battery_j``."""
    text = at
    for part in loc:
        if isinstance(part, int):
            text += f"[{part}]"
        else:
            text += f".{part}" if text and not text.endswith(".") else str(part)
    return text.rstrip(".")


def _unwrap(annotation: Any) -> Any:
    """``annotation`` without ``Annotated`` and ``| None``."""
    while True:
        origin = get_origin(annotation)
        if origin is Annotated:
            annotation = get_args(annotation)[0]
        elif origin in (typing.Union, types.UnionType):
            rest = [a for a in get_args(annotation) if a is not type(None)]
            if len(rest) != 1:
                return annotation
            annotation = rest[0]
        else:
            return annotation


def _fields(model: type[BaseModel]) -> dict[str, FieldInfo]:
    """``model``'s fields by the key a file writes (its alias, when it has one)."""
    return {f.alias or name: f for name, f in model.model_fields.items()}


def _place(
    model: type[BaseModel], loc: tuple[Any, ...]
) -> tuple[type[BaseModel] | None, FieldInfo | None, Any]:
    """Along ``loc`` from ``model``: the last model passed (whose key it is), the field at
    the end (None for an item of a list or table, or a key no model has) and the type
    there."""
    owner: type[BaseModel] | None = None
    field: FieldInfo | None = None
    kind: Any = model
    for part in loc:
        kind = _unwrap(kind)
        if isinstance(kind, type) and issubclass(kind, BaseModel):
            owner, field = kind, _fields(kind).get(str(part))
            kind = field.annotation if field is not None else Any
            continue
        args = get_args(kind)
        origin = get_origin(kind)
        field = None
        if origin in (list, tuple, Sequence) and args:
            kind = args[0]
        elif origin is dict and len(args) == 2:
            kind = args[1]
        else:
            kind = Any
    return owner, field, _unwrap(kind)


def json_kind(value: Any) -> str:
    """What a JSON value is, as a message says what it got: ``an object``, ``a list``,
    ``an empty list``, ``a string`` (each without its content), ``true``, ``3``,
    ``null``."""
    if isinstance(value, dict):
        return "an object"
    if isinstance(value, list | tuple):
        return "a list" if value else "an empty list"
    if isinstance(value, str):
        return "a string"
    try:
        text = json.dumps(value)
    except (TypeError, ValueError):  # a TOML date
        return quoted(value)
    return text if len(text) <= MAX_QUOTED else f"{text[: MAX_QUOTED - 1]}…"


def _got(value: Any) -> str:
    """A value a file holds as a message quotes it: a table or a list by its kind, null
    as JSON writes it, any other as Python reads it (``'12'``, ``2.5``, ``True``)."""
    if isinstance(value, dict | list | tuple) or value is None:
        return json_kind(value)
    return quoted(value)


_WHOLE = frozenset({"int_type", "int_parsing", "int_from_float"})
_NUMBER = frozenset({"float_type", "float_parsing", "finite_number"})
_RANGE = frozenset({"greater_than", "greater_than_equal", "less_than", "less_than_equal"})
_TABLE = frozenset({"model_type", "model_attributes_type", "dict_type"})
_STRUCTURE = _TABLE | {"missing", "list_type"}
"""What a model's ``prefix`` opens: a key of its own missing or not of its kind."""


def _article(noun: str) -> str:
    if noun.startswith(("the ", "a ", "an ")):
        return noun
    return f"an {noun}" if noun[:1] in "aeiou" else f"a {noun}"


def _shape(kind: Any) -> str:
    """What a model's table is: its ``shape``, else its noun and keys (the required
    first): ``a drone {depot, type}``."""
    if not (isinstance(kind, type) and issubclass(kind, FileModel)):
        return "a table"
    if kind.shape:
        return kind.shape
    fields = _fields(kind)
    needed = [k for k, f in fields.items() if f.is_required()]
    keys = ", ".join(needed + ["…"]) if needed and len(needed) < len(fields) else ", ".join(fields)
    return f"{_article(kind.noun)} {{{keys}}}"


def _range(field: FieldInfo | None, name: str, ctx: dict[str, Any]) -> str:
    """The range of a number (``0 < size_km ≤ 200``) from its field's bounds, else from
    the one bound it failed."""
    bounds = dict(ctx)
    for m in field.metadata if field is not None else ():
        for attr in ("gt", "ge", "lt", "le"):
            if getattr(m, attr, None) is not None:
                bounds[attr] = getattr(m, attr)
    low = next(
        (f"{_num(bounds[a])} {s} " for a, s in (("gt", "<"), ("ge", "≤")) if a in bounds), ""
    )
    high = next(
        (f" {s} {_num(bounds[a])}" for a, s in (("lt", "<"), ("le", "≤")) if a in bounds), ""
    )
    if not high:  # one bound: "episode ≥ 0"
        return next(
            f"{name} {s} {_num(bounds[a])}" for a, s in (("gt", ">"), ("ge", "≥")) if a in bounds
        )
    return f"{low}{name}{high}"


def _num(v: Any) -> str:
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e16:
        return str(int(v))
    return str(v)


def _message(err: Any, owner: type[BaseModel] | None, field: FieldInfo | None, kind: Any) -> str:
    """The message of one pydantic error at a place of the file (:func:`_place`)."""
    typ = err["type"]
    loc = err["loc"]
    name = str(loc[-1]) if loc else ""
    noun = getattr(owner, "noun", "table")  # a settings model read from a file may name its own
    # A file model's description says what a value must be; a settings model's (a drone
    # type's parameters) describes the setting, and its range says what it must be.
    own = owner is not None and issubclass(owner, FileModel)
    what = field.description if field is not None and own else None
    got = _got(err.get("input"))
    if typ == "extra_forbidden":
        known = ", ".join(sorted(_fields(owner))) if owner is not None else ""
        listed = f" (expected some of: {known})" if known else ""
        return f"unknown key {name!r} in {_article(noun)}{listed}"
    if typ == "value_error":
        return str(err["msg"]).removeprefix("Value error, ")
    if typ == "missing":
        # A part missing reads as what belongs there; a value, as what its table needs.
        part = get_origin(kind) in (list, dict) or (
            isinstance(kind, type) and issubclass(kind, BaseModel)
        )
        text = (
            f"expected {what}, got nothing" if what and part else f"{_article(noun)} needs {name}"
        )
    elif what:
        text = f"expected {what}, got {got}"
    elif typ in _WHOLE:
        text = f"expected a whole number, got {got}"
    elif typ in _NUMBER:
        text = f"expected a number, got {got}"
    elif typ in _RANGE:
        text = f"expected {_range(field, name or 'x', err.get('ctx') or {})}, got {got}"
    elif typ == "literal_error":
        text = f"expected {err['ctx']['expected']}, got {got}"
    elif typ in _TABLE:
        text = f"expected {_shape(kind)}, got {got}"
    elif typ == "list_type":
        text = f"expected a list, got {got}"
    elif typ == "string_type":
        text = f"expected text, got {got}"
    elif typ == "bool_type":
        text = f"expected true or false, got {got}"
    elif typ in ("too_short", "too_long"):
        ctx = err.get("ctx") or {}
        most = ctx.get("max_length")
        bound = f"at most {most}" if typ == "too_long" else f"at least {ctx.get('min_length')}"
        text = f"expected {bound} entries, got {ctx.get('actual_length')}"
    else:
        text = f"{err['msg']}, got {got}"
    # The model whose key it is opens the message of a key missing or not of its kind;
    # a document not of its kind at all, its own model.
    opener = owner if owner is not None else kind
    if typ in _STRUCTURE and isinstance(opener, type) and issubclass(opener, FileModel):
        text = opener.prefix + text
    return text
