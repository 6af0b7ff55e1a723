"""Policy specs (``--policy``, a method's policy) parsed once into a :class:`PolicySpec`,
and specs -> policy objects."""

from __future__ import annotations

import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from ..errors import InputError, not_a_file
from ..methods import SHIPPED_KINDS, policy_kind, unknown_policy
from .base import Policy
from .landing import check_trained_for

DEFAULT_POLICY_NAME = "marops-basic.pt"
DEFAULT_MAPPO_NAME = "mappo-basic.pt"
DEFAULT_LANDING_NAME = "marops-ops.safetensors"
SHIPPED = dict(zip(SHIPPED_KINDS, (DEFAULT_POLICY_NAME, DEFAULT_MAPPO_NAME), strict=True))
"""A method's shipped actor, by policy kind: the flight-range actor, the MAPPO actor."""
SHIPPED_OPERATING = {"learned": DEFAULT_LANDING_NAME}
"""The shipped actor of a policy kind under an operating model other than the paper's
(docs/method.md §6.1): the landing actor."""

Kind = str
"""A policy kind: a registered one (:func:`~marops_cli.methods.policy_names`), a shipped
actor (``learned``, ``direct``) or ``torchscript`` (a trained actor file)."""


@dataclass(frozen=True)
class PolicySpec:
    """A parsed policy spec: a baseline or landing rule by name (a registered policy
    kind, marops_cli/methods.py), a shipped actor (``learned``, ``direct``) or a trained
    actor file (``torchscript``, with its ``path`` as given)."""

    kind: Kind
    path: str | None = None

    @classmethod
    def parse(cls, spec: str) -> PolicySpec:
        """A registered policy kind's name (:func:`~marops_cli.methods.policy_names`),
        ``learned``, ``direct``, ``torchscript:PATH`` or a ``.pt`` path."""
        why = unknown_policy(spec)
        if why is not None:
            raise InputError(why)
        if spec in SHIPPED or _registered(spec):
            return cls(spec)
        return cls.actor(spec.removeprefix("torchscript:"))

    @classmethod
    def actor(cls, path: str | Path) -> PolicySpec:
        """The trained actor file at ``path``."""
        return cls("torchscript", str(path))

    @property
    def loads_actor(self) -> bool:
        """Whether the policy flies a trained actor (which needs torch)."""
        return self.kind == "torchscript" or self.kind in SHIPPED

    def shipped(self, paper: bool = True) -> PolicySpec | None:
        """A shipped actor's spec as its file's (None: this install ships none), the one
        for the paper's operating model or (``paper`` False) for the realistic one; any
        other spec as it is."""
        if self.kind not in SHIPPED:
            return self
        name = SHIPPED[self.kind] if paper else SHIPPED_OPERATING.get(self.kind, SHIPPED[self.kind])
        path = default_policy_path(name)
        return None if path is None else PolicySpec.actor(path)

    def __str__(self) -> str:
        return f"torchscript:{self.path}" if self.kind == "torchscript" else self.kind


def actor_files(path: str | Path) -> list[Path]:
    """Every file an actor at ``path`` may be read from: the path as given, its
    TorchScript ``.pt``, weights ``.safetensors`` and sidecar ``.json``."""
    path = Path(path)
    return [path, *(path.with_suffix(s) for s in (".pt", ".safetensors", ".json"))]


def default_policy_path(name: str = DEFAULT_POLICY_NAME) -> Path | None:
    """The shipped actor: ``$MAROPS_POLICY``, else ``marops-basic.pt`` of the installed
    package data (``policies/`` in the source tree, ``marops_cli.shipped`` once installed).

    ``name`` picks another shipped actor: ``marops-ops.safetensors``, the realistic
    model's, which ``$MAROPS_POLICY`` replaces too (the default actor of ``marops``
    whatever the model), or ``mappo-basic.pt``, which it does not replace.
    """
    env = os.environ.get("MAROPS_POLICY")
    if env and name in (DEFAULT_POLICY_NAME, DEFAULT_LANDING_NAME):
        if not Path(env).name:  # '.', '/': a folder, whose actor files have no name
            raise InputError(f"MAROPS_POLICY names no actor file, got {env!r}")
        return Path(env)
    try:
        found = resources.files("marops_cli.shipped") / name
    except ModuleNotFoundError:  # an install without the package data
        return None
    path = Path(str(found))
    return path if path.is_file() else None


def make_policy(
    spec: str | PolicySpec, seed: int = 0, *, trust: bool = False, model: str = "paper"
) -> Policy:
    """The policy of ``spec`` (a :class:`PolicySpec` or its text, see
    :meth:`PolicySpec.parse`); ``seed`` seeds the random baseline. A trained actor loads
    from its weights file; ``trust`` (``--trust-actor``) lets a TorchScript file without
    one load, running its code (docs/method.md §6, "Trust model of actor files");
    ``model`` is the run's operating model (:func:`~.landing.operating_model`): it picks the
    shipped actors, and an actor trained for another refuses to load (docs/method.md §6.1)."""
    if isinstance(spec, str):
        spec = PolicySpec.parse(spec)
    resolved = spec.shipped(model == "paper")
    if resolved is None:
        raise InputError(f"no trained actor is shipped at policies/{SHIPPED[spec.kind]}")
    spec = resolved
    if spec.kind != "torchscript":  # a registered kind (a shipped actor resolved above)
        policy: Policy = policy_kind(spec.kind).build(seed)
        return policy
    assert spec.path is not None
    path = spec.path
    if path.endswith(".safetensors"):  # data only: a landing actor, or a recurrent one's
        from ..data.jsonfile import read_json
        from .landing import load_landing_actor

        weights = Path(path)
        if not weights.is_file():
            raise not_a_file(weights, "policy file")
        sidecar = weights.with_suffix(".json")
        doc = read_json(sidecar, "actor sidecar")
        if not _recurrent(doc):
            actor = load_landing_actor(weights, doc, sidecar)
            actor.check_model(model)
            return actor
        # The recurrent actor's weights and sidecar, shared without its TorchScript file:
        # rebuilt from the weights as with the file, which it no longer needs.
        path = str(weights.with_suffix(".pt"))
    from .torchscript import TorchScriptPolicy, read_sidecar

    side = read_sidecar(path)
    # A sidecar written before marops recorded the model names none: any model.
    check_trained_for(side.get("operating_model"), model, path)
    if "plan_slots" in side:  # a MAPPO actor: destination x plan slot
        from .direct import DirectPolicy

        return DirectPolicy(Path(path), trust=trust)
    return TorchScriptPolicy(Path(path), trust=trust)


def landing_actor_file(path: str | Path) -> bool:
    """Whether ``path`` is a landing actor's weights file (``.safetensors`` whose sidecar
    is the landing actor's), which loads without torch; a file that cannot be read says
    no (it fails when it loads, naming itself)."""
    from ..data.jsonfile import read_json

    weights = Path(path)
    if weights.suffix != ".safetensors" or not weights.is_file():
        return False
    try:
        doc = read_json(weights.with_suffix(".json"), "actor sidecar")
    except InputError:
        return False
    return not _recurrent(doc)


def _recurrent(doc: object) -> bool:
    """A sidecar of the recurrent actor (``marops-actor/N``), not the landing actor's."""
    return isinstance(doc, dict) and str(doc.get("format", "")).startswith("marops-actor/")


def _registered(name: str) -> bool:
    """Whether ``name`` is a registered policy kind (marops_cli/methods.py)."""
    try:
        policy_kind(name)
    except KeyError:
        return False
    return True
