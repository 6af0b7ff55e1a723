"""The flight-range policy protocol and the window view that policies read."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal, Protocol, runtime_checkable

import numpy as np

from ..errors import InputError
from ..plans.select import Selector
from ..plans.view import WindowView

if TYPE_CHECKING:
    from ..config import PlannerConfig

MAX_WEIGHT = 1e6
"""The largest magnitude of a weight in an actor's weights file (docs/method.md §6,
"Trust model of actor files"): trained weights are of order 1 (the shipped actors' under
2), and far beyond, a logit or a landing score overflows to infinity."""


def check_weight_range(largest: float, file: Path, tensor: str) -> None:
    """Refuse a weights file whose tensor ``tensor`` holds a weight of magnitude
    ``largest`` beyond :data:`MAX_WEIGHT`, naming the file and the tensor."""
    if largest > MAX_WEIGHT:
        raise InputError(
            f"holds a weight of magnitude {largest:.3g}, beyond the {MAX_WEIGHT:.0e} an "
            "actor's weights may reach (trained weights are of order 1)",
            file=file,
            column=tensor,
        )


def check_header_keys(path: Path) -> None:
    """Refuse a safetensors file whose JSON header gives a key twice, as every other
    JSON marops reads is refused (the safetensors reader keeps the last one unsaid).
    The file's size is bounded by the caller; a header that does not read is left to the
    safetensors reader's own error."""
    from ..data.jsonfile import parse_json

    with open(path, "rb") as f:
        head = f.read(8)
        size = int.from_bytes(head, "little") if len(head) == 8 else 0
        text = f.read(size) if 0 < size <= path.stat().st_size else b""
    try:
        parse_json(text)
    except ValueError as exc:
        if "appears twice" in str(exc):
            raise InputError(f"not a safetensors weights file ({exc})", file=path) from None


SLOT_PLANNER = "subsets"
"""The planner whose plans a policy that picks plans by slot ranks (the MAPPO baseline:
the paper's subset plans, docs/method.md §4.5)."""


@dataclass(frozen=True)
class SlotActions:
    """One window's choices of a policy that picks the plans itself (the MAPPO baseline):
    each drone's action, as :meth:`Policy.act` returns them, and the plan slot it picked
    (:class:`~.direct.SlotSelector` flies it)."""

    actions: np.ndarray
    slots: np.ndarray


@runtime_checkable
class Policy(Protocol):
    """Chooses each drone's destination among its depot's action candidates.

    ``scope`` is ``"range"`` for the paper's flight ranges and ``"global"`` for the
    whole-map baseline (the planner then ignores the actions). A policy that picks the
    plans itself (the MAPPO baseline) brings its ``selector`` and the ``planner`` whose
    plans it ranks; others leave both None. ``identity`` is what output files record
    (the actor file, or the policy's name).
    """

    name: str
    scope: Literal["range", "global"]
    planner: str | None
    selector: Selector | None

    @property
    def identity(self) -> str | Path: ...

    def configure(self, cfg: PlannerConfig) -> None:
        """Receive the run's planner settings (a policy that prices plans needs them)."""
        ...

    def reset(self, seed: int) -> None:
        """Start a new day (recurrent state, random streams)."""
        ...

    def act(self, view: WindowView) -> np.ndarray | SlotActions:
        """Action index (0 = stay) for every drone, shape ``(U,)``; a policy that picks
        the plans itself adds each drone's plan slot (:class:`SlotActions`)."""
        ...


class PolicyBase:
    """The protocol's defaults: a flight-range policy that needs no settings."""

    name: str = "policy"
    scope: Literal["range", "global"] = "range"
    planner: str | None = None
    selector: Selector | None = None

    @property
    def identity(self) -> str | Path:
        return self.name

    def configure(self, cfg: PlannerConfig) -> None:
        return None

    def reset(self, seed: int) -> None:
        return None


def start_day(policy: Policy, cfg: PlannerConfig, seed: int) -> None:
    """Hand a policy the run's planner settings and start its day."""
    policy.configure(cfg)
    policy.reset(seed)
