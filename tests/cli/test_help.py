"""Every command and every option explains itself."""

from __future__ import annotations

import re

import typer
from typer.testing import CliRunner

from marops_cli.cli.app import app

runner = CliRunner()


def _commands() -> dict:
    group = typer.main.get_command(app)
    return dict(group.commands)  # type: ignore[attr-defined]


def _flat(output: str) -> str:
    """Help text as one line: panel borders out, runs of spaces and line breaks as one."""
    return " ".join(re.sub(r"[│╭╮╰╯─]", " ", output).split())


def test_root_help_lists_every_command() -> None:
    result = runner.invoke(app, ["--help"])
    assert result.exit_code == 0
    for name in _commands():
        assert name in result.output


def test_every_command_and_option_has_help() -> None:
    commands = _commands()
    assert {"synth", "segment"} <= set(commands)
    for name, cmd in commands.items():
        assert cmd.help and len(cmd.help.strip()) > 10, name
        for param in cmd.params:
            if param.param_type_name == "option":
                assert param.help and param.help.strip(), f"{name} {param.opts} has no help"
        result = runner.invoke(app, [name, "--help"])
        assert result.exit_code == 0, name
        assert "Usage" in result.output


def test_bracketed_defaults_survive_rendering() -> None:
    # "[default: kmeans]" is how help texts give a default; rich markup would read it as
    # a style tag and drop it from the rendered help.
    seen = 0
    for name, cmd in _commands().items():
        output = _flat(runner.invoke(app, [name, "--help"]).output)
        for param in cmd.params:
            for default in re.findall(r"\[default: [^\]]+\]", param.help or ""):
                assert " ".join(default.split()) in output, (name, param.opts, default)
                seen += 1
    assert seen > 10  # kmeans, marops, exact, 16, 8, ...


def test_defaults_are_written_one_way() -> None:
    """Every default reads ``[default: X]``, typer's own and the help texts' alike: not
    ``[16]``, ``(default: X)`` or ``(default X)``."""
    for name in _commands():
        output = _flat(runner.invoke(app, [name, "--help"]).output)
        assert "(default" not in output, name
        assert not re.search(r"\[(?!default: |required\]|env var: )[^\[\]]*\]\.", output), name
        assert "[default: " in output, name


def test_each_default_is_given_once() -> None:
    """An option whose help text writes its default does not get typer's as well."""
    import click

    for name, cmd in _commands().items():
        ctx = click.Context(cmd)
        for param in cmd.params:
            record = param.get_help_record(ctx)
            if record is not None:
                assert record[1].count("[default: ") <= 1, (name, param.opts, record[1])


def test_usage_names_the_data_as_it_is_typed() -> None:
    for name in ("segment", "plan-window", "replay-day", "evaluate"):
        output = _flat(runner.invoke(app, [name, "--help"]).output)
        assert f"Usage: marops {name} [OPTIONS] DATA " in output, output
        assert "{data}" not in output and re.search(r"DATA <path> ", output)
    output = _flat(runner.invoke(app, ["train", "--help"]).output)
    assert "Usage: marops train [OPTIONS] DATA... " in output
    assert re.search(r"DATA(\.\.\.)? <path> ", output) and "list[" not in output


def test_version() -> None:
    from marops_cli import __version__

    for flag in ("--version", "-V"):
        result = runner.invoke(app, [flag])
        assert result.exit_code == 0
        assert result.output == f"marops {__version__}\n"
