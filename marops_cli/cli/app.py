"""The ``marops`` command-line application."""

from __future__ import annotations

import atexit
import contextlib
import os
import signal
import sys
import threading
import warnings
from typing import Annotated, Any, NoReturn

import typer
import typer.core

from .. import __version__
from .common import INTERRUPTED, PLAIN, STATE, error_json, one_line, say_stopped, stop_signal
from .evaluate_cmd import evaluate_command
from .plan_window_cmd import plan_window_command
from .replay_cmd import replay_day_command
from .report_cmd import report_command
from .segment_cmd import segment_command
from .synth_cmd import synth_command
from .train_cmd import train_command
from .usage import Command, Group, env_sourced, options_part

app = typer.Typer(
    name="marops",
    cls=Group,
    help="Operations planner for drone last-mile delivery (MAR-OPS): LaDe export -> depots -> "
    "flight ranges -> energy-aware multi-parcel routes, window by window.",
    no_args_is_help=False,  # a bare `marops` is a usage error: one line, as every other
    add_completion=False,
    pretty_exceptions_enable=False,
    # Help texts give defaults as "[default: kmeans]": rich markup would take them for style tags
    # and drop them; markdown keeps them and the rich panels.
    rich_markup_mode="markdown",
    context_settings={"help_option_names": ["-h", "--help"]},
)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"marops {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    debug: Annotated[
        bool,
        typer.Option(
            "--debug",
            help="Show a full traceback when something fails (before or after the command).",
        ),
    ] = False,
    version: Annotated[
        bool,
        typer.Option(
            "--version", "-V", callback=_version, is_eager=True, help="Print the version."
        ),
    ] = False,
) -> None:
    """Operations planner for drone last-mile delivery."""
    STATE.update(debug=debug, quiet=False, json=False, stopped=False)
    from ..io.ownership import new_run

    new_run()  # each command decides (--force) and registers its inputs


app.command("synth", cls=Command)(synth_command)
app.command("segment", cls=Command)(segment_command)
app.command("plan-window", cls=Command)(plan_window_command)
app.command("replay-day", cls=Command)(replay_day_command)
app.command("train", cls=Command)(train_command)
app.command("evaluate", cls=Command)(evaluate_command)
app.command("report", cls=Command)(report_command)


def _terminate(signum: int, frame: object) -> None:
    """SIGTERM unwinds like Ctrl-C (temporaries removed, one line, exit 143)."""
    from ..io.atomic import TERM_RECEIVED, Terminated

    TERM_RECEIVED.set()
    raise Terminated()


def _interrupt(signum: int, frame: object) -> None:
    """Ctrl-C as Python's own handler takes it (KeyboardInterrupt), noted so that an
    interruption a library swallows still ends the run as one (cli/common.py)."""
    INTERRUPTED.set()
    raise KeyboardInterrupt


def _unraisable(args: Any) -> None:
    """Ctrl-C or SIGTERM that Python could not raise (its handler ran in a finaliser or a
    weakref callback, where an exception is printed as ignored, with a traceback, and
    the run went on to its end and exit 0): the signal is sent again, from a timer's
    thread so that it lands after this hook, to be taken where the run stops as from any
    other point. Other such exceptions print as before."""
    from ..io.atomic import Terminated

    if isinstance(args.exc_value, KeyboardInterrupt):
        sig = signal.SIGTERM if isinstance(args.exc_value, Terminated) else signal.SIGINT
        again = threading.Timer(0.05, _again, (sig,))  # once the hook is done
        again.daemon = True
        again.start()
        return
    sys.__unraisablehook__(args)


_LEAVING = threading.Event()
"""Set once the process ends (:func:`_leave`): a stop sent again then would cut its exit
handlers short."""


def _again(sig: int) -> None:
    """Send ``sig`` to this process again, unless the run has taken a stop already (the
    command reported one) or is ending."""
    if not STATE["stopped"] and not _LEAVING.is_set():
        os.kill(os.getpid(), sig)


def _one_line_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: object = None,
    line: str | None = None,
) -> None:
    """Library warnings (scikit-learn, cvxpy, torch) as our own one-line messages."""
    text = " ".join(str(message).split())
    typer.echo(f"warning: {one_line(text)}", err=True)


def _run() -> int | str | None:
    """The command line's exit status (an int, a message for stderr, or None for 0)."""
    if PLAIN:  # help and messages as plain text for logs and pipes
        typer.core.HAS_RICH = False
    signal.signal(signal.SIGTERM, _terminate)
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:  # not when ignored
        signal.signal(signal.SIGINT, _interrupt)
    sys.unraisablehook = _unraisable
    warnings.showwarning = _one_line_warning
    try:
        code = app(standalone_mode=False)
    except SystemExit as exc:  # the commands' own exits (sys.exit(2) on bad input, ...)
        return exc.code
    except typer.Abort:  # Ctrl-C or SIGTERM that click took as it read the command line
        return stopped_early(stop_signal() or KeyboardInterrupt())
    except Exception as exc:  # usage errors (unknown option, bad value, missing argument)
        message = getattr(exc, "format_message", None)
        if message is None:
            raise
        ctx = getattr(exc, "ctx", None)
        hint = f" (see '{ctx.command_path} --help')" if ctx is not None else ""
        text = _named_source(" ".join(str(message()).split()), getattr(exc, "param", None), ctx)
        if text == "Missing command." and ctx is not None:  # a bare `marops`: name them
            text = f"Missing command: one of {', '.join(ctx.command.list_commands(ctx))}."
        typer.echo(f"marops: error: {one_line(text)}{hint}", err=True)
        status = int(getattr(exc, "exit_code", 2))
        if ctx is not None and _wants_json(ctx.command):
            error_json(_command_name(ctx), f"{text}{hint}", status)
        return status
    signalled = stop_signal()
    if code == 130 and signalled is not None and not STATE["stopped"]:
        # Typer ends a Ctrl-C or SIGTERM that came while it read the command line, before
        # the command could take it, with a bare exit 130.
        return stopped_early(signalled)
    return code if isinstance(code, int) else 0


def stopped_early(signalled: KeyboardInterrupt) -> int:
    """A Ctrl-C or SIGTERM that came before a command could take it (as marops started,
    or while its command line was read): its line (:func:`~.common.say_stopped`) and,
    where the line asks for ``--json`` of a command that has it, the JSON document a stop
    during the command writes (unless the command wrote it); the exit code."""
    said = STATE["stopped"]  # a stop the command reported, its document included
    line, code = say_stopped(signalled)
    name = _line_command()
    if not said and name is not None and _json_asked():
        error_json(name, line, code)
    return code


def _line_command() -> str | None:
    """The command the command line names (its first word after the group's switches)
    when that command has ``--json``; None for any other line."""
    import inspect

    words = [a for a in options_part(sys.argv[1:]) if not a.startswith("-")]
    for info in app.registered_commands if words else ():
        if info.name == words[0] and info.callback is not None:
            return words[0] if "as_json" in inspect.signature(info.callback).parameters else None
    return None


def _named_source(text: str, param: Any, ctx: Any) -> str:
    """A bad value's line names where it came from: the environment variable only when
    the value was read from it (click's parameter source, :func:`~.usage.env_sourced`;
    click names the variable whenever the option has one), and the value itself
    (``--drones abc``: ``, got 'abc'``)."""
    opts = tuple(getattr(param, "opts", ()))
    envvar = getattr(param, "envvar", None)
    names = [envvar] if isinstance(envvar, str) else list(envvar or ())
    from_env = env_sourced(ctx) if ctx is not None and param is not None else {}
    var = next((from_env[o] for o in opts if o in from_env), None)
    given = os.environ.get(var) if var is not None else None
    args = sys.argv[1:]
    for i, arg in enumerate(options_part(args) if var is None else ()):
        if arg in opts and i + 1 < len(args):
            given = args[i + 1]
        elif arg.split("=", 1)[0] in opts and "=" in arg:
            given = arg.split("=", 1)[1]
    for name in names:
        if name != var:
            text = text.replace(f" (env var: '{name}')", "")
    if given is not None and text.startswith("Invalid value for") and "got " not in text:
        text = f"{text.rstrip('.')}, got {given!r}"
    return text


def _wants_json(command: object) -> bool:
    """Whether a command line that failed before its command ran asked for ``--json``
    (on the line, or ``MAROPS_JSON`` as the option reads it), of a command that has it
    or of a command name marops does not know (the failing command is then the group)."""
    known = any(getattr(p, "name", None) == "as_json" for p in getattr(command, "params", []))
    if not known and not hasattr(command, "commands"):
        return False
    return _json_asked()


def _json_asked() -> bool:
    """Whether the command line asks for ``--json`` (on the line, or ``MAROPS_JSON`` as
    the option reads it)."""
    if "--json" in options_part(sys.argv[1:]):
        return True
    return os.environ.get("MAROPS_JSON", "").strip().lower() in _TRUE


def _command_name(ctx: Any) -> str:
    """The command an error document names: the command's own, or for a name marops
    does not know, that name as typed."""
    if not hasattr(ctx.command, "commands"):
        return str(ctx.info_name)
    words = [a for a in sys.argv[1:] if not a.startswith("-")]
    return words[0] if words else str(ctx.info_name)


_TRUE = ("1", "true", "t", "yes", "y", "on")
"""The values a boolean option takes for true from its environment variable."""


def _leave(code: int | str | None) -> NoReturn:
    """End the process once the command is done, without tearing the interpreter down.

    Exit handlers still run and the standard streams are flushed; what is skipped is
    freeing every module's objects one by one, which took 0.3–0.4 s after torch had
    been imported (docs/decisions.md, "Start-up and exit"). Every file the commands
    write is closed (and renamed into place) before they return.
    """
    if code is None:
        status = 0
    elif isinstance(code, int):
        status = code
    else:  # sys.exit("message"): the message goes to stderr, status 1
        print(code, file=sys.stderr)
        status = 1
    _LEAVING.set()
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(status)


def main() -> None:
    """The console script: every error is one plain line on stderr (docs/outputs.md)."""
    from ..workers.threads import portable_blas

    portable_blas()  # before any library computes
    try:
        code = _run()
    except (KeyboardInterrupt, Exception) as exc:
        # Ctrl-C or SIGTERM before a command handles it (as marops starts), or an error
        # it caused in a half-imported library: one line, no traceback.
        signalled = exc if isinstance(exc, KeyboardInterrupt) else stop_signal()
        if signalled is None or STATE["debug"]:
            raise
        code = stopped_early(signalled)
    _leave(code)
