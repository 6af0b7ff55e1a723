"""A trained actor file with its JSON sidecar (docs/method.md §6).

The actor's contract is ``forward(obs, hidden) -> (logits, hidden)`` with ``obs`` of
shape ``(U, obs_dim)`` and ``hidden`` of shape ``(U, hidden_size)``. Its weights load as
data from the safetensors file beside it (:mod:`.weights`); the TorchScript file itself,
which runs its author's code when loaded, only with ``trust`` (``--trust-actor``) and no
weights file. Loading needs torch only: no training code is imported.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal

from ..config import clipped
from ..data.jsonfile import first_line, read_json, refuse_misspelt_keys
from ..errors import InputError, not_a_file, option, quoted
from .base import WindowView
from .observation import OBS_VERSION, OBS_VERSIONS, n_choices, obs_dim
from .recurrent import RecurrentPolicy

SIDECAR_BOUNDS = {
    "obs_version": 1_000,
    "n_actions": 4096,  # segment.n_actions' bound: an actor of more never runs
    "hidden_size": 4096,
    "obs_dim": 100_000,
    "n_logits": 100_000,
    "plan_slots": 100_000,
}
"""The sidecar's counts, each a whole number from 1 to its bound, checked before any
network is built or called (a TorchScript actor's first call, too, allocates by them);
the weights' bounds are :data:`~.weights.MAX_SIZES`."""


SIDECAR_KEYS = (*SIDECAR_BOUNDS, "format", "weights_sha256", "operating_model")
"""The sidecar's keys the loader reads; its others are provenance, kept as they are."""


def sidecar_path(model_path: str | Path) -> Path:
    """``policies/marops-basic.pt`` -> ``policies/marops-basic.json``."""
    return Path(model_path).with_suffix(".json")


def read_sidecar(model_path: str | Path) -> dict[str, Any]:
    """The sidecar of the actor file ``model_path``, checked; the file itself may be
    missing where its weights file is there (the actor is rebuilt from them)."""
    if not _present(model_path):
        raise not_a_file(model_path, "policy file")
    side = sidecar_path(model_path)
    doc = read_json(side, "policy sidecar beside the .pt file")
    if not isinstance(doc, dict):
        raise InputError("policy sidecar must be a JSON object", file=side)
    refuse_misspelt_keys(doc, SIDECAR_KEYS, side)
    for key in ("obs_version", "n_actions", "hidden_size"):
        if key not in doc:
            raise InputError("policy sidecar lacks a field", file=side, column=key)
    for key, bound in SIDECAR_BOUNDS.items():
        value = doc.get(key)
        if key in doc and (
            isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= bound
        ):
            raise InputError(
                f"expected a whole number from 1 to {bound:,}, got {clipped(repr(value))}",
                file=side,
                column=key,
            )
    model = doc.get("operating_model")  # none: a sidecar from before marops recorded it
    if model is not None and (not isinstance(model, str) or not model):
        raise InputError(
            f"expected the operating model the actor was trained for, got {quoted(model)}",
            file=side,
            column="operating_model",
        )
    if int(doc["obs_version"]) not in OBS_VERSIONS:
        raise InputError(
            f"policy was trained on observation version {doc['obs_version']}, "
            f"this marops reads versions {', '.join(str(int(v)) for v in OBS_VERSIONS)} "
            f"(it trains version {int(OBS_VERSION)}); retrain it",
            file=side,
            column="obs_version",
        )
    # The network reads obs_dim features while the policy observes what obs_version
    # lays out: a disagreement would only surface as a shape error in the first window.
    width = obs_dim(int(doc["n_actions"]), int(doc["obs_version"]))
    if "obs_dim" in doc and doc["obs_dim"] != width:
        raise InputError(
            f"obs_dim {doc['obs_dim']} disagrees with obs_version {doc['obs_version']}, "
            f"whose observation of {doc['n_actions']} actions has {width} features",
            file=side,
            column="obs_dim",
        )
    return doc


def _present(model_path: str | Path) -> bool:
    """The actor file is there, or its weights file is (all a data-only actor needs)."""
    from .weights import weights_path

    return Path(model_path).is_file() or weights_path(model_path).is_file()


MAX_TORCHSCRIPT_BYTES = 1 << 30
"""A TorchScript actor is read whole (hashed and loaded from the same bytes): at most 1 GiB."""


def load_module(path: Path, side: dict[str, Any], trust: bool) -> Any:
    """The actor of ``path`` in eval mode: rebuilt from the weights file beside it when
    there is one, else the TorchScript module, loaded only when ``trust`` is given or
    this installation trained it (:mod:`.installation`)."""
    # Deferred: the network imports torch, which the other policies never pay for.
    from .installation import trained_here
    from .weights import load_weights, weights_path

    weights = weights_path(path)
    if weights.is_file():
        return load_weights(path, side, sidecar_path(path))
    if os.path.lexists(weights):  # a folder, a pipe, a broken link: never taken for none
        raise not_a_file(weights, "weights file")
    if path.stat().st_size > MAX_TORCHSCRIPT_BYTES:
        raise InputError(f"larger than {MAX_TORCHSCRIPT_BYTES:,} bytes", file=path)
    # The bytes judged are the bytes loaded: the file cannot change in between.
    data = path.read_bytes()
    if not trust and not trained_here(data):
        raise InputError(
            f"no weights file {weights_path(path).name} beside this actor, this installation "
            "did not train it, and loading TorchScript runs its author's code: pass "
            f"--trust-actor if you trust its author, or ask them for {weights.name}, the "
            "weights file marops train writes beside it",
            file=path,
        )
    import io

    import torch  # deferred: importing torch costs a second the other policies never pay

    try:
        with warnings.catch_warnings():
            # torch 2.13 marks TorchScript deprecated; the format is our artifact contract.
            warnings.simplefilter("ignore", DeprecationWarning)
            module = torch.jit.load(io.BytesIO(data), map_location="cpu")
    except (RuntimeError, ValueError) as exc:
        raise InputError(f"not a TorchScript module ({exc})", file=path) from exc
    module.eval()
    return module


class TorchScriptPolicy(RecurrentPolicy):
    """Greedy (arg-max) actions of a trained actor file and its sidecar (the network
    rebuilt from its weights, or its TorchScript when trusted), flown by the one drive of
    every recurrent actor (:class:`~.recurrent.RecurrentPolicy`)."""

    scope: Literal["range", "global"] = "range"

    def __init__(
        self,
        path: str | Path,
        *,
        slots: Callable[[int], Any] | None = None,
        trust: bool = False,
    ) -> None:
        """``slots`` makes the selector of an actor with plan slots (the MAPPO baseline:
        its sidecar names ``plan_slots``) from their number; ``trust`` lets a TorchScript
        file without a weights file beside it load (and run its code)."""
        self.path = Path(path)
        if not _present(self.path):
            raise not_a_file(self.path, "policy file")
        self.sidecar = read_sidecar(self.path)
        if slots is not None and "plan_slots" not in self.sidecar:
            raise InputError("not a MAPPO actor: its sidecar has no plan_slots", file=self.path)
        n_slots = int(self.sidecar["plan_slots"]) if slots is not None else 1
        module = load_module(self.path, self.sidecar, trust)
        super().__init__(
            module,
            int(self.sidecar["n_actions"]),
            int(self.sidecar["hidden_size"]),
            int(self.sidecar["obs_version"]),
            n_slots=n_slots,
            selector=None if slots is None else slots(n_slots),
            name=f"torchscript:{self.path.name}",
        )
        self._probe()

    def _probe(self) -> None:
        """One call with the shapes the sidecar promises: ``forward(obs (2, obs_dim),
        hidden (2, hidden_size)) -> (logits (2, n_logits), hidden (2, hidden_size))``."""
        torch = self._torch
        side = self.sidecar
        slots = int(side.get("plan_slots", 1))
        width = int(side.get("obs_dim", obs_dim(self.n_actions, self.obs_version)))
        choices = n_choices(self.n_actions, self.obs_version)
        n_logits = int(side.get("n_logits", choices * slots))
        expect = (
            f"forward(obs ({width} features), hidden ({self.hidden_size})) -> "
            f"(logits ({n_logits}), hidden ({self.hidden_size}))"
        )
        try:
            with torch.no_grad():
                out = self._module(
                    torch.zeros((2, width), dtype=torch.float32),
                    torch.zeros((2, self.hidden_size), dtype=torch.float32),
                )
        except Exception as exc:  # any failure of a foreign module is a bad policy file
            first = first_line(exc)
            raise InputError(
                f"the actor does not run as {expect}: {first}", file=self.path
            ) from None
        ok = (
            isinstance(out, tuple)
            and len(out) == 2
            and all(isinstance(t, torch.Tensor) for t in out)
            and tuple(out[0].shape) == (2, n_logits)
            and tuple(out[1].shape) == (2, self.hidden_size)
        )
        if not ok:
            got = (
                tuple(tuple(t.shape) for t in out if isinstance(t, torch.Tensor))
                if isinstance(out, tuple)
                else type(out).__name__
            )
            raise InputError(f"the actor returns {got}, expected {expect}", file=self.path)
        if n_logits != choices * slots:
            what = "n_actions + 1 (free landing)" if choices > self.n_actions else "n_actions"
            raise InputError(
                f"the sidecar's n_logits {n_logits} is not {what} × plan_slots "
                f"({choices} × {slots})",
                file=sidecar_path(self.path),
            )

    @property
    def identity(self) -> str | Path:
        """The actor's file; its weights file where it was shared without one."""
        from .weights import weights_path

        return self.path if self.path.is_file() else weights_path(self.path)

    def _check(self, view: WindowView) -> None:
        n, a = view.depots.candidates.shape
        if a != self.n_actions:
            fix = (
                f"segment at least {self.n_actions} depots ({option('n_depots')})"
                if n < self.n_actions  # each depot's candidates are itself and its nearest
                else f"segment with {option('actions')} {self.n_actions}"
            )
            raise InputError(
                f"the policy expects {self.n_actions} actions per depot, "
                f"the {n} depots offer {a}; {fix}",
                file=self.path,
            )
