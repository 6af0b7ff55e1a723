"""Every benchmark script has a smoke mode (``--smoke``: its own code on the least input,
once), and CI runs each in it, so no script falls behind the library unnoticed."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# Scripts, not helper modules (a leading underscore).
SCRIPTS = sorted(p for p in (ROOT / "benchmarks").glob("*.py") if not p.name.startswith("_"))


def _options(path: Path) -> set[str]:
    """The option strings of every ``add_argument`` call in ``path`` (read, not run)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return {
        arg.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Call)
        and isinstance(node.func, ast.Attribute)
        and node.func.attr == "add_argument"
        for arg in node.args
        if isinstance(arg, ast.Constant) and isinstance(arg.value, str)
    }


def test_there_are_benchmark_scripts():
    assert len(SCRIPTS) >= 10


@pytest.mark.parametrize("path", SCRIPTS, ids=lambda p: p.name)
def test_every_benchmark_script_has_a_smoke_mode(path: Path):
    assert "--smoke" in _options(path), f"benchmarks/{path.name} has no --smoke option"


def test_ci_runs_every_benchmark_script_in_its_smoke_mode():
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    loop = next((line for line in ci.splitlines() if line.startswith("for script in ")), "")
    assert "benchmarks/[!_]*.py" in loop, "CI has no loop over the benchmark scripts"
    assert "python '$script' --smoke" in ci
