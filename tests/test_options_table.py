"""One table of the config-backed options (marops_cli/app/options.py): an option registered
there, and nowhere else, is a flag of its commands (help, value, environment variable),
a keyword of its API function (checked as its type) and a config override, its range
the config field's."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from marops_cli import api as marops
from marops_cli.app import options as table
from marops_cli.app.options import OPTIONS, OptionSpec, planner_config, registered
from marops_cli.cli.app import app
from marops_cli.errors import InputError, flag, keyword

runner = CliRunner()

N_INIT = OptionSpec(
    "n_init",
    "segment.n_init",
    int,
    "k-means restarts [default: 4].",
    ("segment",),
    envvar="MAROPS_N_INIT",
)


@pytest.fixture
def n_init() -> Iterator[OptionSpec]:
    """``--n-init`` (``[segment] n_init``, not an option of any command) for ``segment``."""
    with registered(N_INIT) as spec:
        yield spec


@pytest.fixture
def seen(monkeypatch: pytest.MonkeyPatch) -> None:
    """``segment`` stops at once, saying the config it was given: no clustering run."""
    import marops_cli.app.segment as use_case

    def stop(data: Any, cfg: Any, **kwargs: Any) -> Any:
        raise InputError(f"seen n_init={cfg.segment.n_init}")

    monkeypatch.setattr(use_case, "segment", stop)


def _segment(example_csv: Path, out: Path, *args: str, **env: str) -> Any:
    return runner.invoke(app, ["segment", str(example_csv), "--out", str(out), *args], env=env)


def test_an_option_registered_in_the_table_is_a_flag_a_keyword_and_a_setting(
    n_init: OptionSpec, seen: None, example_csv: Path, tmp_path: Path
) -> None:
    out = tmp_path / "depots.json"
    help_text = " ".join(runner.invoke(app, ["segment", "--help"]).output.split())
    assert "--n-init" in help_text and "k-means restarts [default: 4]." in help_text
    assert "MAROPS_N_INIT" in help_text
    # On the command line, from its environment variable, and the flag before the variable.
    assert "seen n_init=2" in _segment(example_csv, out, "--n-init", "2").output
    assert "seen n_init=3" in _segment(example_csv, out, MAROPS_N_INIT="3").output
    assert "seen n_init=2" in _segment(example_csv, out, "--n-init", "2", MAROPS_N_INIT="3").output
    # The range is the config field's (1 ≤ n_init ≤ 1000), named as the flag.
    bad = _segment(example_csv, out, "--n-init", "0")
    assert bad.exit_code == 2
    assert "invalid option --n-init: Input should be greater than or equal to 1" in bad.output
    # In the API: a keyword, its type checked, its range named as the keyword.
    with pytest.raises(InputError, match="^seen n_init=5$"):
        marops.segment(example_csv, n_init=5)
    with pytest.raises(InputError, match="^seen n_init=6$"):
        marops.segment(example_csv, n_init="6")  # a number's text, as for every int keyword
    with pytest.raises(InputError, match=r"^segment\(\): n_init expects an integer, got str"):
        marops.segment(example_csv, n_init="many")
    with pytest.raises(InputError, match="^invalid option n_init: Input should be greater"):
        marops.segment(example_csv, n_init=0)
    assert planner_config(None, n_init=7).segment.n_init == 7
    assert not out.exists()


def test_an_option_leaves_with_its_entry(example_csv: Path) -> None:
    with registered(N_INIT):
        assert "--n-init" in runner.invoke(app, ["segment", "--help"]).output
    assert "--n-init" not in runner.invoke(app, ["segment", "--help"]).output
    with pytest.raises(InputError, match=r"unexpected keyword argument 'n_init'"):
        marops.segment(example_csv, n_init=5)
    with pytest.raises(TypeError, match="n_init"):
        planner_config(None, n_init=5)


def test_an_option_is_registered_once() -> None:
    with pytest.raises(ValueError, match="'alpha'"), registered(OPTIONS["alpha"]):
        pass
    assert "alpha" in OPTIONS


def test_the_table_names_options_as_the_error_messages_do() -> None:
    # errors.py spells an option's flag and keyword where they differ from its name.
    for spec in OPTIONS.values():
        assert flag(spec.name) == spec.flag_text, spec.name
        assert keyword(spec.name) == spec.param, spec.name


def test_each_option_sets_a_config_field() -> None:
    from marops_cli.config import STAGES

    for spec in OPTIONS.values():
        stage, _, name = spec.field.partition(".")
        assert name in STAGES[stage].model_fields, spec.name
        assert set(spec.uses) <= set(table.USES), spec.name


def test_a_command_lists_the_options_it_places_where_it_places_them() -> None:
    output = runner.invoke(app, ["plan-window", "--help"]).output
    flags = re.findall(r"(--[a-z-]+)", output)
    assert flags.index("--drones") < flags.index("--delivered") < flags.index("--policy")
