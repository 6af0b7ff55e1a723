"""An actor's weights as data: ``NAME.safetensors`` beside ``NAME.pt``, rebuilt into the
known network (:class:`~.network.Actor`) from the sizes its sidecar gives.

Importing this module does not import torch (the network does, when an actor is
rebuilt): naming a weights file (:func:`weights_path`) is part of every output's
metadata, also for runs that fly no recurrent actor (docs/decisions.md, "Start-up and
exit").

Nothing of the file runs: a safetensors file is a JSON header and raw numbers. Every
tensor's name, shape and dtype is checked against the network the sidecar describes, and
the sizes against the bounds below, before anything is allocated; its values must be
finite and within :data:`~.base.MAX_WEIGHT` (docs/method.md §6, "Trust model of actor
files").
"""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar, Literal

from ..errors import InputError
from .base import Tensors, check_weight_range, read_tensors

if TYPE_CHECKING:
    from .network import Actor

ACTOR_FORMAT = "marops-actor/1"
"""The sidecar's ``format`` of an actor whose weights rebuild :class:`~.network.Actor`."""
# Bounds on the network a sidecar may describe, so that a hostile sidecar cannot make the
# loader allocate gigabytes; the shipped actors have 64 units and at most 99 features.
MAX_SIZES = {"obs_dim": 100_000, "n_logits": 100_000, "hidden_size": 4096}
MAX_PARAMETERS = 1 << 25
"""At most 33,554,432 weights (128 MiB of float32)."""


def weights_path(model_path: str | Path) -> Path:
    """``policies/marops-basic.pt`` -> ``policies/marops-basic.safetensors``."""
    return Path(model_path).with_suffix(".safetensors")


@functools.cache
def _sizes_model() -> type[Any]:
    """The part of a sidecar that rebuilds the network: its format and sizes, each a
    whole number within :data:`MAX_SIZES`; its other keys are kept as written (built on
    first use: pydantic is imported for a recurrent actor only)."""
    from pydantic import ConfigDict, Field

    from ..data.filemodel import FileModel, Whole

    def size(key: str) -> Any:
        bound = MAX_SIZES[key]
        return Field(ge=1, le=bound, description=f"a whole number from 1 to {bound}")

    class ActorSizes(FileModel):
        model_config = ConfigDict(extra="ignore")
        noun: ClassVar[str] = "actor's sidecar"
        format: Literal["marops-actor/1"] = Field(
            description=f"format {ACTOR_FORMAT!r} to rebuild the network from its weights"
        )
        obs_dim: Whole = size("obs_dim")
        n_logits: Whole = size("n_logits")
        hidden_size: Whole = size("hidden_size")

    return ActorSizes


def network_sizes(side: dict[str, Any], sidecar: Path) -> tuple[int, int, int]:
    """``(obs_dim, n_logits, hidden_size)`` of the sidecar ``side`` (read from the file
    ``sidecar``), each a whole number within :data:`MAX_SIZES`."""
    from ..data.filemodel import validated  # deferred: pydantic, for a recurrent actor only
    from .network import actor_shapes  # deferred: the network imports torch

    sizes = validated(_sizes_model(), side, sidecar)
    obs, logits, hidden = (getattr(sizes, key) for key in MAX_SIZES)
    n = sum(math.prod(s) for s in actor_shapes(obs, logits, hidden).values())
    if n > MAX_PARAMETERS:
        raise InputError(
            f"the network it describes has {n:,} weights, more than the bound {MAX_PARAMETERS:,}",
            file=sidecar,
            column="hidden_size",
        )
    return obs, logits, hidden


def load_weights(model_path: str | Path, side: dict[str, Any], sidecar: Path) -> Actor:
    """The actor of ``model_path``'s weights file, in eval mode, after checking each
    tensor against the network of the sidecar ``side``."""
    import torch

    from .network import Actor, actor_shapes

    path = weights_path(model_path)
    sizes = network_sizes(side, sidecar)
    expect = actor_shapes(*sizes)
    limit = 4 * sum(math.prod(s) for s in expect.values()) + (1 << 20)  # data + header
    if path.stat().st_size > limit:
        raise InputError(
            f"larger than the network its sidecar describes ({limit:,} bytes)", file=path
        )
    f = read_tensors(path, limit)
    _check_tensors(f, expect, path)
    state = {name: torch.from_numpy(f.float32(name)) for name in expect}
    _check_digest(path, side, sidecar)  # a well-formed file, but is it this actor's?
    for name, tensor in state.items():
        if not bool(torch.isfinite(tensor).all()):
            raise InputError("NaN or infinite weights", file=path, column=name)
        check_weight_range(float(tensor.abs().max()) if tensor.numel() else 0.0, path, name)
    with torch.device("meta"):  # no allocation, no initialisation: the weights replace them
        actor = Actor(*sizes)
    actor.load_state_dict(state, assign=True)
    return actor.eval()


def _check_digest(path: Path, side: dict[str, Any], sidecar: Path) -> None:
    """The weights are the ones the sidecar was written with (``weights_sha256``, written
    by marops train; sidecars from before it have none)."""
    want = side.get("weights_sha256")
    if want is None:
        return
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(1 << 20):
            h.update(block)
    if h.hexdigest() != want:
        raise InputError(
            f"its weights_sha256 is not the SHA-256 of {path.name}: weights and sidecar "
            "come from different actors",
            file=sidecar,
            column="weights_sha256",
        )


def _check_tensors(f: Tensors, expect: dict[str, tuple[int, ...]], path: Path) -> None:
    """Raise unless the safetensors file ``f`` holds exactly the tensors of ``expect``,
    float32 and of those shapes (read from its header, before any data)."""
    names = f.names()
    extra = sorted(names - expect.keys())
    if extra:
        raise InputError("a tensor the actor network does not have", file=path, column=extra[0])
    for name, shape in expect.items():
        if name not in names:
            raise InputError("the actor network's tensor is missing", file=path, column=name)
        got, dtype = f.shape(name), f.dtype(name)
        if dtype != "F32" or got != shape:
            raise InputError(
                f"expected float32 {list(shape)} (the sidecar's network), got {dtype} {list(got)}",
                file=path,
                column=name,
            )
