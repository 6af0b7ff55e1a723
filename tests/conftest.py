"""Shared fixtures: the bundled example and a scenario built from it once per session."""

from __future__ import annotations

from pathlib import Path

import pytest

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "shanghai_synth.csv"


@pytest.fixture(scope="session")
def example_csv() -> Path:
    assert EXAMPLE.is_file(), "examples/shanghai_synth.csv is part of the repository"
    return EXAMPLE
