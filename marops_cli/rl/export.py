"""The trained actor as a self-describing artifact: TorchScript, weights and JSON sidecar
(docs/method.md §6).

``X.pt`` holds ``forward(obs, hidden) -> (logits, hidden)`` and loads with plain
``torch.jit.load`` (which runs the file's code: marops does so only with
``--trust-actor``); ``X.safetensors`` holds the same weights as data, which marops
rebuilds into the known network; ``X.json`` says how to feed it (observation version,
number of actions, network sizes) and how it was made (data hash, command, seed, config,
held-out metrics), so anyone can check or re-train it; ``X.curve.png`` draws the
training curve.
"""

from __future__ import annotations

import io
import warnings
from pathlib import Path
from typing import Any, NamedTuple

import torch

from ..io.atomic import output_set
from ..policies.installation import record_trained, sha256_bytes
from ..policies.observation import OBS_VERSION, ObsVersion
from ..policies.weights import ACTOR_FORMAT, weights_path
from .networks import Actor


def script_actor(actor: Actor) -> torch.jit.ScriptModule:
    """A TorchScript copy of the actor (CPU, eval mode); the training object is untouched."""
    clone = Actor(actor.encoder.in_features, actor.head.out_features, actor.hidden_size)
    clone.load_state_dict(actor.state_dict())
    clone.eval()
    with warnings.catch_warnings():
        # torch 2.13 deprecates TorchScript, but docs/method.md §6 names it as the artifact format.
        warnings.simplefilter("ignore", DeprecationWarning)
        return torch.jit.script(clone)


def actor_bytes(actor: Actor) -> bytes:
    buf = io.BytesIO()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        torch.jit.save(script_actor(actor), buf)
    return buf.getvalue()


def weights_bytes(actor: Actor) -> bytes:
    """The actor's weights as a safetensors file (names of its state dict, float32)."""
    from safetensors.torch import save

    state = {
        k: v.detach().to("cpu", torch.float32).contiguous() for k, v in actor.state_dict().items()
    }
    return save(state)


class Written(NamedTuple):
    """A trained actor as written: its sidecar, and whether this installation's record of
    the actors it trained notes it."""

    sidecar: dict[str, Any]
    """The sidecar document written (docs/method.md §6)."""
    recorded: bool
    """False when the TorchScript actor went unrecorded (the record a symbolic link, a
    pipe or read-only): it then loads by its weights file, or with ``--trust-actor``.
    True for the landing actor, whose weights file needs no record."""


def write_actor(actor: Actor, path: str | Path, sidecar: dict[str, Any]) -> Written:
    """Write ``path`` (TorchScript), its ``.safetensors`` weights and its ``.json`` sidecar
    together, atomically, and notes the TorchScript file in this installation's record
    of the actors it trained (marops_cli/policies/installation.py).

    The sidecar gets the fields the loader requires (``obs_version``, ``n_actions``,
    ``hidden_size``) and the weights' SHA-256 (``weights_sha256``, checked on loading)
    on top of ``sidecar``; returns the document written and whether the record notes it.
    """
    path = Path(path)
    script, weights = actor_bytes(actor), weights_bytes(actor)
    doc = {
        "format": ACTOR_FORMAT,
        "obs_version": int(OBS_VERSION),
        "obs_dim": actor.encoder.in_features,
        "n_logits": actor.head.out_features,
        "hidden_size": actor.hidden_size,
        "weights_sha256": sha256_bytes(weights),
        "torch": torch.__version__,
        **sidecar,
    }
    if "n_actions" not in doc:  # version 4 adds the free landing to the destinations
        free = int(doc["obs_version"]) >= ObsVersion.ANTICIPATION
        doc["n_actions"] = actor.head.out_features - (1 if free else 0)
    with output_set() as files:
        files.write_bytes(path, script)
        files.write_bytes(weights_path(path), weights)
        files.write_json(path.with_suffix(".json"), doc)
        if doc.get("learning_curve"):
            from .curve import curve_png

            files.write_bytes(path.with_suffix(".curve.png"), curve_png(doc))
    return Written(doc, record_trained(script, path))
