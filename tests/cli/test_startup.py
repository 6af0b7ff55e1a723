"""Starting the CLI loads no heavy library: they load in the command that needs them."""

from __future__ import annotations

import json
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# Loaded only by the commands that use them; dask and distributed only with --scheduler
# (an optional extra, README.md "Sweeps on a cluster").
HEAVY = ("torch", "cvxpy", "highspy", "sklearn", "scipy", "matplotlib", "dask", "distributed")


def test_cli_start_loads_no_heavy_module() -> None:
    code = (
        "import json, sys; import marops_cli.cli.app; "
        f"print(json.dumps(sorted(m for m in {HEAVY!r} if m in sys.modules)))"
    )
    res = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout) == []


def test_distributed_is_optional_but_tested() -> None:
    """The base install leaves distributed out; the cluster, test and dev extras bring it."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert not any(d.startswith(("distributed", "dask")) for d in project["dependencies"])
    for extra in ("cluster", "test", "dev"):
        assert any(d.startswith("distributed") for d in project["optional-dependencies"][extra])
