"""The methods a run can use and the policies named by a word, defined once
(docs/method.md §7).

A method is a segmentation (service areas) and a flight-range policy; everything that
lists methods — command help, ``evaluate``'s default list, the checks of
``--method`` — reads this registry, so adding a method is one :func:`register` call.
A policy named by a word (``--policy greedy``, a method's policy) is a
:class:`PolicyKind`: the policy specs, ``--policy``'s help and the API's checks read
them here. A landing rule is both, one :func:`landing_rule` entry beside its class
(docs/decisions.md, "Adding a landing rule").
Light on purpose (no numpy, no torch): the command-line help imports it, so a built-in
policy names its class by ``"module:Class"``, imported when it flies.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import PurePath
from typing import Any, Literal

__all__ = [
    "METHODS",
    "Method",
    "PolicyKind",
    "landing_rule",
    "method_names",
    "policy_kind",
    "policy_kinds",
    "policy_names",
    "reference_rules",
    "register",
    "register_kind",
    "SHIPPED_KINDS",
    "unknown_policy",
]


@dataclass(frozen=True)
class PolicyKind:
    """A flight-range policy named by a word: a baseline or a landing rule."""

    name: str
    policy: str | type
    """Its class (built with no argument, or the seed when ``seeded``), or the class as
    ``"module:Class"``, imported when it flies."""
    summary: str
    seeded: bool = False
    """Built with the run's seed (``random``)."""
    landing_rule: bool = False
    """One of the operating model's landing rules (docs/method.md §7)."""

    def build(self, seed: int = 0) -> Any:
        """A new policy of this kind (``seed``: the run's, for a ``seeded`` one)."""
        cls = self.policy
        if isinstance(cls, str):
            module, _, name = cls.partition(":")
            cls = getattr(importlib.import_module(module), name)
        return cls(seed) if self.seeded else cls()


@dataclass(frozen=True)
class Method:
    """One method: its name, service areas, policy kind, and how it is listed."""

    name: str
    segmentation: Literal["kmeans", "squares"]
    policy: str
    """A policy spec (``PolicySpec.parse`` of marops_cli/policies/registry.py reads it):
    a :class:`PolicyKind`'s name, ``learned`` (the shipped actor), ``direct`` (the
    shipped MAPPO actor) or an actor file. Text, so that this registry stays light."""
    summary: str
    in_default_evaluation: bool = True
    """In ``evaluate``'s list when ``--methods`` is not given (references are not)."""
    kind: PolicyKind | None = None
    """The policy kind the method brings (a landing rule's), registered with it: a
    worker that registers the method knows its policy too."""
    reference: bool = False
    """One of the rules the landing actor must beat in training (marops_cli/rl/es.py)."""


_REGISTRY: dict[str, Method] = {}


_KINDS: dict[str, PolicyKind] = {}
_ACTORS = ("learned", "direct", "torchscript")  # kinds of PolicySpec no class stands for


def register(method: Method) -> Method:
    """Add (or replace) a method, and the policy kind it brings; it is then valid
    everywhere a method is named."""
    if method.kind is not None:
        register_kind(method.kind)
    _REGISTRY[method.name] = method
    return method


def register_kind(kind: PolicyKind) -> PolicyKind:
    """Add (or replace) a policy kind; ``--policy`` and a method's policy may name it."""
    if kind.name in _ACTORS:
        raise ValueError(f"{kind.name!r} names the trained actors' policy kinds")
    _KINDS[kind.name] = kind
    return kind


def landing_rule(
    name: str,
    policy: str | type,
    summary: str,
    *,
    reference: bool = False,
    in_default_evaluation: bool = True,
) -> Method:
    """Register a landing rule: the policy kind ``name`` (its class ``policy``, built with
    no argument) and the method of the same name flying it over k-means areas, listed in
    help texts with ``summary``; ``reference``: one of the rules the landing actor must
    beat in training."""
    kind = PolicyKind(name, policy, summary, landing_rule=True)
    return register(Method(name, "kmeans", name, summary, in_default_evaluation, kind, reference))


_BASE = "marops_cli.policies.baselines:"
_RULES = "marops_cli.policies.rules:"
for _k in (
    PolicyKind("stay", _BASE + "StayPolicy", "always back to the start depot"),
    PolicyKind("random", _BASE + "RandomPolicy", "a random neighbouring area", seeded=True),
    PolicyKind("greedy", _BASE + "GreedyPolicy", "the area with most waiting delay per metre"),
    PolicyKind("global", _BASE + "GlobalPolicy", "whole map, nearest-depot landing"),
    PolicyKind("myopic", _BASE + "MyopicPolicy", "the best value now (the actor's teacher)"),
):
    register_kind(_k)
for _m in (
    Method("marops", "kmeans", "learned", "learned flight range (the shipped actor)"),
    Method("ops-global", "kmeans", "global", "whole map, nearest-depot landing", reference=True),
    Method("ops-random", "kmeans", "random", "random neighbouring area"),
    Method("greedy", "kmeans", "greedy", "the area with most waiting delay per metre"),
):
    register(_m)
# The operating model's landing rules (docs/method.md, "Operating model"): the learned
# actor's strongest non-learned rivals there. A new rule is its class and one line here.
landing_rule(
    "backlog",
    _RULES + "BacklogPolicy",
    "land where most waiting value per drone is",
    reference=True,
)
landing_rule(
    "rebalance",
    _RULES + "RebalancePolicy",
    "land to match the coming demand per depot",
    reference=True,
)
landing_rule(
    "flow",
    _RULES + "FlowPolicy",
    "min-cost flow of drones to the coming work, batteries kept",
    reference=True,
)
landing_rule(
    "battery",
    _RULES + "BatteryPolicy",
    "backlog, never landing where no spare battery is",
    reference=True,
)
for _m in (
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


def policy_kind(name: str) -> PolicyKind:
    """The registered policy kind ``name`` (KeyError when there is none)."""
    return _KINDS[name]


def policy_kinds() -> list[PolicyKind]:
    """Every registered policy kind, baselines first, in the order registered."""
    return list(_KINDS.values())


def policy_names() -> str:
    """``"stay, random, …"``: the policies named by a word, for help texts and errors."""
    return ", ".join(_KINDS)


SHIPPED_KINDS = ("learned", "direct")
"""The policy kinds that fly an actor marops ships: the flight-range actor, the MAPPO
actor (their files: marops_cli/policies/registry.py, ``SHIPPED``)."""


def unknown_policy(spec: str) -> str | None:
    """Why ``spec`` names no policy (None when it does: a registered policy kind's name,
    a shipped actor's kind, ``torchscript:PATH`` or an actor file's ``.pt`` or
    ``.safetensors`` path; the file itself is read later). The config checks a
    ``[sim] policy`` with it, and the policy registry parses every spec by it."""
    if spec in SHIPPED_KINDS or spec in _KINDS:
        return None
    if spec.startswith("torchscript:") and not PurePath(spec.removeprefix("torchscript:")).name:
        return f"torchscript:PATH names no actor file, got {spec!r}"
    if spec.startswith("torchscript:") or spec.endswith((".pt", ".safetensors")):
        return None
    return (
        f"unknown policy {spec!r}: expected one of {policy_names()}, "
        "torchscript:PATH, a .pt file or an actor's .safetensors file"
    )


def reference_rules() -> dict[str, str]:
    """The rules the landing actor must beat in training, in registry order (each
    day's best of them, the first on ties: marops_cli/rl/es.py): method -> policy spec."""
    return {m.name: m.policy for m in _REGISTRY.values() if m.reference}
