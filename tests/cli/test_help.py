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
    # "[kmeans]" is how help texts give a default; rich markup would read it as a style
    # tag and drop it from the rendered help.
    seen = 0
    for name, cmd in _commands().items():
        output = runner.invoke(app, [name, "--help"]).output
        for param in cmd.params:
            for default in re.findall(r"\[[^\]\s]+\]", param.help or ""):
                assert default in output, (name, param.opts, default)
                seen += 1
    assert seen > 10  # kmeans, marops, exact, 16, 8, ...


def test_version() -> None:
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0
    assert result.output.startswith("marops ")
