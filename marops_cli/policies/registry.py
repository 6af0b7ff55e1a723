"""Policy names on the command line -> policy objects."""

from __future__ import annotations

from pathlib import Path

from ..errors import InputError
from .base import Policy
from .baselines import GlobalPolicy, GreedyPolicy, MyopicPolicy, RandomPolicy, StayPolicy

SIMPLE = ("stay", "random", "greedy", "global", "myopic")


def make_policy(spec: str, seed: int = 0) -> Policy:
    """``stay``, ``random``, ``greedy``, ``global``, ``myopic``, ``torchscript:PATH`` or a
    ``.pt`` path."""
    if spec == "stay":
        return StayPolicy()
    if spec == "random":
        return RandomPolicy(seed)
    if spec == "greedy":
        return GreedyPolicy()
    if spec == "global":
        return GlobalPolicy()
    if spec == "myopic":
        return MyopicPolicy()
    path = spec.removeprefix("torchscript:")
    if spec.startswith("torchscript:") or path.endswith(".pt"):
        from .torchscript import TorchScriptPolicy, read_sidecar

        if "plan_slots" in read_sidecar(path):  # a MAPPO actor: destination x plan slot
            from .direct import DirectPolicy

            return DirectPolicy(Path(path))
        return TorchScriptPolicy(Path(path))
    raise InputError(
        f"unknown policy {spec!r}: expected one of {', '.join(SIMPLE)}, "
        "torchscript:PATH or a .pt file"
    )
