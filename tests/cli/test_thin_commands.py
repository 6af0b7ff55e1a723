"""Commands stay thin (docs/decisions.md, "Application layer"): a command reads its flags
into a config, calls one application function and renders the result, so no function
of a ``cli/*_cmd.py`` module runs past 30 lines after its docstring."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

CLI = Path(__file__).resolve().parents[2] / "marops_cli" / "cli"
LIMIT = 30


def _bodies(path: Path) -> dict[str, int]:
    """Lines of each module-level function's body (its docstring aside)."""
    sizes = {}
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        body = node.body
        if isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
            body = body[1:] or body  # a function that is only a docstring is one line
        end = body[-1].end_lineno or body[-1].lineno
        sizes[node.name] = end - body[0].lineno + 1
    return sizes


def test_the_command_modules_are_found() -> None:
    names = {p.name for p in CLI.glob("*_cmd.py")}
    assert {"replay_cmd.py", "plan_window_cmd.py", "segment_cmd.py", "synth_cmd.py"} <= names


@pytest.mark.parametrize("path", sorted(CLI.glob("*_cmd.py")), ids=lambda p: p.name)
def test_no_command_function_runs_past_30_lines(path: Path) -> None:
    long = {name: n for name, n in _bodies(path).items() if n > LIMIT}
    assert not long, f"{path.name}: bodies over {LIMIT} lines: {long}"


def test_the_measure_skips_the_docstring(tmp_path: Path) -> None:
    src = tmp_path / "x_cmd.py"
    src.write_text('def f():\n    """Doc\n    string."""\n    a = 1\n    return a\n')
    assert _bodies(src) == {"f": 2}
