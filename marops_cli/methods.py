"""The methods a run can use, defined once (docs/method.md §7).

A method is a segmentation (service areas) and a flight-range policy; everything that
lists methods — command help, ``evaluate``'s default list, the checks of
``--method`` — reads this registry, so adding a method is one :func:`register` call.
Light on purpose (no numpy, no torch): the command-line help imports it.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Literal

__all__ = ["METHODS", "Method", "method_names", "register"]


@dataclass(frozen=True)
class Method:
    """One method: its name, service areas, policy kind, and how it is listed."""

    name: str
    segmentation: Literal["kmeans", "squares"]
    policy: str
    """A policy spec (``PolicySpec.parse`` of marops_cli/policies/registry.py reads it):
    ``learned`` (the shipped actor), ``direct`` (the shipped MAPPO actor), ``global``,
    ``random``, ``greedy``, ``backlog``, ``rebalance``, ``flow``, ``battery``, ``stay``,
    ``myopic``, or an actor file. Text, so that this registry stays light."""
    summary: str
    in_default_evaluation: bool = True
    """In ``evaluate``'s list when ``--methods`` is not given (references are not)."""


_REGISTRY: dict[str, Method] = {}


def register(method: Method) -> Method:
    """Add (or replace) a method; it is then valid everywhere a method is named."""
    _REGISTRY[method.name] = method
    return method


for _m in (
    Method("marops", "kmeans", "learned", "learned flight range (the shipped actor)"),
    Method("ops-global", "kmeans", "global", "whole map, nearest-depot landing"),
    Method("ops-random", "kmeans", "random", "random neighbouring area"),
    Method("greedy", "kmeans", "greedy", "the area with most waiting delay per metre"),
    # The operating model's landing rules (docs/method.md, "Operating model"): the
    # learned actor's strongest non-learned rivals there.
    Method("backlog", "kmeans", "backlog", "land where most waiting value per drone is"),
    Method("rebalance", "kmeans", "rebalance", "land to match the coming demand per depot"),
    Method("flow", "kmeans", "flow", "min-cost flow of drones to the coming work, batteries kept"),
    Method("battery", "kmeans", "battery", "backlog, never landing where no spare battery is"),
    Method("squares", "squares", "learned", "learned flight range on a square grid"),
    Method("mappo", "kmeans", "direct", "the MAPPO actor picks plans, no optimiser"),
    Method("stay", "kmeans", "stay", "always back to the start depot", False),
    Method("myopic", "kmeans", "myopic", "the best value now (the actor's teacher)", False),
):
    register(_m)


class _Table(Mapping[str, tuple[str, str]]):
    """``METHODS[name] -> (segmentation, policy)``, live over the registry; new code
    reads the typed record, :func:`method`."""

    def __getitem__(self, name: str) -> tuple[str, str]:
        m = _REGISTRY[name]
        return m.segmentation, m.policy

    def __iter__(self) -> Iterator[str]:
        return iter(list(_REGISTRY))

    def __len__(self) -> int:
        return len(_REGISTRY)


METHODS: Mapping[str, tuple[str, str]] = _Table()


def method(name: str) -> Method:
    """The registry entry of method ``name`` (KeyError when there is none)."""
    return _REGISTRY[name]


def method_names() -> str:
    """``"marops, ops-global, …"`` for help texts."""
    return ", ".join(_REGISTRY)


def reference_names() -> str:
    """The methods ``evaluate`` runs only when asked (``"stay and myopic"``)."""
    refs = [m.name for m in _REGISTRY.values() if not m.in_default_evaluation]
    return " and ".join([", ".join(refs[:-1]), refs[-1]] if len(refs) > 1 else refs)
