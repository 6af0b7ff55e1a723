"""How the commands present themselves: usage lines and argument types as they are
written on a command line (``marops segment [OPTIONS] DATA``, ``DATA...  <path>``),
and ``--debug`` after a command's name as before it."""

from __future__ import annotations

from contextvars import ContextVar
from pathlib import PurePath
from typing import Any, get_args

import typer
import typer.core


class Argument(typer.core.TyperArgument):
    """A positional argument shown by its metavar: ``DATA`` (typer writes a required one
    ``{data}``), ``DATA...`` for several, ``[DATA]`` when it may be left out; the type of
    a list is its items' (``<path>``, not ``<list[Path]>``)."""

    def _usage_display_name(self) -> str:
        name = self.metavar or (self.name or "").upper()
        name += "..." if self.nargs != 1 else ""
        return name if self.required else f"[{name}]"

    def _rich_display_name(self) -> str:
        return self._usage_display_name().strip("[]")

    def display_type(self, ctx: Any) -> str:
        desc = self.type_descriptor
        if desc.is_list and not desc.is_choice:
            (item,) = get_args(desc.annotation)
            is_path = isinstance(item, type) and issubclass(item, PurePath)
            return "<path>" if is_path else f"<{self._bare_type(item)}>"
        return super().display_type(ctx)


class Group(typer.core.TyperGroup):
    """The ``marops`` command group: ``--debug`` may follow the command's name
    (``marops replay-day DATA … --debug``) as well as come before it."""

    def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
        return super().parse_args(ctx, hoist_debug(args))


def options_part(args: list[str]) -> list[str]:
    """The part of a command line that holds options: everything before a ``--``, after
    which every word is an argument."""
    return args[: args.index("--")] if "--" in args else args


def hoist_debug(args: list[str]) -> list[str]:
    """``args`` with a ``--debug`` given after the command (before any ``--``) moved in
    front of it, where the group reads it."""
    end = len(options_part(args))
    if "--debug" not in args[:end]:
        return args
    return ["--debug", *(a for i, a in enumerate(args) if i >= end or a != "--debug")]


class Command(typer.core.TyperCommand):
    """A marops command: its arguments shown as :class:`Argument`; a path given as an
    empty string is bad usage (:func:`refuse_empty_path`)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        for param in self.params:
            if type(param) is typer.core.TyperArgument:
                param.__class__ = Argument  # the same state, shown the way above
            if _takes_paths(param):
                refuse_empty_path(param)

    def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
        """The command line's usage errors all know their command: click's parser raises
        "Option '--date' requires an argument." without one, which left that line
        without its help hint and, with ``--json``, without its JSON document."""
        line = list(args)  # click's parser consumes the list it is given
        try:
            rest = super().parse_args(ctx, args)
        except Exception as exc:  # click's UsageError, wherever this typer keeps click
            if hasattr(exc, "format_message") and getattr(exc, "ctx", False) is None:
                exc.ctx = ctx  # type: ignore[attr-defined]
            raise
        if not ctx.resilient_parsing:
            refuse_overridden(self, ctx, line)
        return rest

    def invoke(self, ctx: Any) -> Any:
        """Run the command, its context known to :func:`invoked` meanwhile (where each
        option's value came from, for its errors: marops_cli/cli/common.py)."""
        token = _INVOKED.set(ctx)
        try:
            return super().invoke(ctx)
        finally:
            _INVOKED.reset(token)


ONCE = {"config": "a run reads one config file"}
"""Options a command line may give once (name -> why): a second ``--config`` replaced
the first unsaid, where a reader may take the two files to be merged."""


def refuse_overridden(command: Any, ctx: Any, line: list[str]) -> None:
    """Refuse, as a usage error before any work, a command line on which one option
    would override another unsaid: an option of :data:`ONCE` given twice, or two options
    of a pair of :data:`~marops_cli.app.options.EXCLUSIVE` (``--drones`` and ``--fleet``)
    both given on it. A value from an environment variable or a config file is not given
    on the line: an option overrides it, as documented (docs/config.md)."""
    from ..app.options import refuse_both
    from ..errors import InputError

    _, _, order = command.make_parser(ctx).parse_args(args=list(line))
    for param in command.params:
        times = sum(p is param for p in order)
        if param.name in ONCE and times > 1:
            flag = param.opts[0]
            raise Overridden(
                f"{flag} given {times} times: {ONCE[param.name]}, and the last {flag} "
                f"would replace the others unsaid; give {flag} once (merge the files)",
                ctx,
            )
    on_line = {
        p.name: ctx.params.get(p.name)
        for p in command.params
        if p.name and getattr(ctx.get_parameter_source(p.name), "name", None) == "COMMANDLINE"
    }
    try:
        refuse_both(on_line)
    except InputError as exc:
        raise Overridden(str(exc), ctx) from None


class Overridden(Exception):
    """A command line on which one option overrides another (:func:`refuse_overridden`):
    a usage error, reported as click's are (one line naming the command's help, exit 2,
    with ``--json`` its document; marops_cli/cli/app.py)."""

    exit_code = 2

    def __init__(self, text: str, ctx: Any) -> None:
        super().__init__(text)
        self.ctx = ctx

    def format_message(self) -> str:
        return str(self)


_INVOKED: ContextVar[Any] = ContextVar("invoked", default=None)


def invoked() -> Any:
    """The context of the command running now (None outside one)."""
    return _INVOKED.get()


def env_sourced(ctx: Any) -> dict[str, str]:
    """Each flag of ``ctx``'s command whose value came from its environment variable
    (click's parameter source), with that variable: ``{"--drones": "MAROPS_DRONES"}``."""
    import os

    found: dict[str, str] = {}
    for param in ctx.command.params:
        source = ctx.get_parameter_source(param.name) if param.name else None
        if getattr(source, "name", None) != "ENVIRONMENT":
            continue
        envvar = param.envvar
        names = [envvar] if isinstance(envvar, str) else list(envvar or ())
        var = next((n for n in names if os.environ.get(n)), None)  # click's first set
        if var is not None:
            found.update(dict.fromkeys(param.opts, var))
    return found


def _takes_paths(param: Any) -> bool:
    desc = getattr(param, "type_descriptor", None)
    if desc is None:
        return False
    kind = get_args(desc.annotation)[0] if desc.is_list else desc.annotation
    return isinstance(kind, type) and issubclass(kind, PurePath)


def refuse_empty_path(param: Any) -> None:
    """Make ``param`` (a path, or a list of them) refuse an empty string: ``Path("")`` is
    the current folder, so ``--out "$UNSET"`` would write there, and ``--config ""`` be
    called a folder. One line naming the option instead, exit 2."""
    process = param.process_value

    def process_value(ctx: Any, value: Any) -> Any:
        values = value if isinstance(value, list | tuple) else [value]
        if any(isinstance(v, str) and not v for v in values):
            raise typer.BadParameter("expected a path, got an empty string", ctx=ctx, param=param)
        return process(ctx, value)

    param.process_value = process_value
