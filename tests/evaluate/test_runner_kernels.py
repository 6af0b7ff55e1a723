"""An evaluation's worker loads the route pool's compiled kernels before its first job,
so the first job's running time does not carry their loading (docs/outputs.md)."""

from __future__ import annotations

import pytest

import marops_cli.plans.kernels as kernels
from marops_cli.evaluate import runner


@pytest.mark.parametrize(("env", "loads"), [(None, 1), ("1", 1), ("0", 0)])
def test_a_worker_loads_the_kernels_at_setup_unless_they_are_off(
    monkeypatch: pytest.MonkeyPatch, env: str | None, loads: int
) -> None:
    calls: list[int] = []
    monkeypatch.setattr(runner, "load", lambda prep: None)
    monkeypatch.setattr(kernels, "load_kernels", lambda: calls.append(1))
    if env is None:
        monkeypatch.delenv(kernels.JIT_ENV, raising=False)
    else:
        monkeypatch.setenv(kernels.JIT_ENV, env)
    runner.EvaluateWork(prep=None, actors={}).setup()  # type: ignore[arg-type]
    assert len(calls) == loads
