"""Imports run one way: api | cli > app > evaluate, rl > sim > io > policies > plans >
segment > energy > config > data > workers > methods > errors (pyproject's import-linter
contract; the API and the CLI are independent siblings over the application layer),
function-level imports included; no import cycle at any level of the package; nothing
below the CLI imports typer or rich; the data layer never imports the settings' models."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_import_layers_are_kept() -> None:
    lint = Path(sys.executable).parent / "lint-imports"
    res = subprocess.run(
        [str(lint), "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=300
    )
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-2000:]
    assert "4 kept, 0 broken" in res.stdout
    for name in ("Stages import downward only", "No import cycles"):
        assert f"{name} KEPT" in res.stdout
