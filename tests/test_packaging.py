"""The package as installed: every subpackage listed, the shipped actors as package data."""

from __future__ import annotations

import tomllib
from pathlib import Path

from marops_cli.policies.registry import (
    DEFAULT_MAPPO_NAME,
    DEFAULT_POLICY_NAME,
    default_policy_path,
)

ROOT = Path(__file__).resolve().parents[1]


def test_every_subpackage_is_listed_for_the_wheel():
    setup = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(setup["packages"])
    on_disk = {
        ".".join(p.parent.relative_to(ROOT).parts)
        for p in (ROOT / "marops_cli").rglob("__init__.py")
    }
    assert on_disk <= listed, f"not in pyproject's packages: {sorted(on_disk - listed)}"
    assert setup["package-dir"] == {"marops_cli.shipped": "policies"}
    assert {"*.pt", "*.safetensors"} <= set(setup["package-data"]["marops_cli.shipped"])


def test_shipped_actors_are_found_through_the_package(monkeypatch):
    monkeypatch.delenv("MAROPS_POLICY", raising=False)
    for name in (DEFAULT_POLICY_NAME, DEFAULT_MAPPO_NAME):
        path = default_policy_path(name)
        assert path is not None and path.is_file()
        assert path.with_suffix(".json").is_file()
        assert path.with_suffix(".safetensors").is_file()  # the weights every command loads
        assert path.read_bytes() == (ROOT / "policies" / name).read_bytes()
