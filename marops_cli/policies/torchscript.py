"""A trained actor exported as TorchScript, with its JSON sidecar (SPEC §6).

The module's contract is ``forward(obs, hidden) -> (logits, hidden)`` with
``obs`` of shape ``(U, obs_dim)`` and ``hidden`` of shape ``(U, hidden_size)``.
Loading needs torch only: no training code is imported.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..errors import InputError
from ..io.jsonfile import read_json
from .base import WindowView
from .observation import OBS_VERSION, obs_dim, observe


def sidecar_path(model_path: str | Path) -> Path:
    """``policies/marops-basic.pt`` -> ``policies/marops-basic.json``."""
    return Path(model_path).with_suffix(".json")


def read_sidecar(model_path: str | Path) -> dict[str, Any]:
    side = sidecar_path(model_path)
    doc = read_json(side, "policy sidecar beside the .pt file")
    for key in ("obs_version", "n_actions", "hidden_size"):
        if key not in doc:
            raise InputError("policy sidecar lacks a field", file=side, column=key)
    if int(doc["obs_version"]) != OBS_VERSION:
        raise InputError(
            f"policy was trained on observation version {doc['obs_version']}, "
            f"this marops builds version {OBS_VERSION}; retrain it",
            file=side,
            column="obs_version",
        )
    return doc


class TorchScriptPolicy:
    """Greedy (arg-max) actions of a recurrent TorchScript actor."""

    scope: Literal["range", "global"] = "range"

    def __init__(self, path: str | Path) -> None:
        import torch  # deferred: importing torch costs a second the other policies never pay

        self.path = Path(path)
        if not self.path.is_file():
            raise InputError("policy file not found", file=self.path)
        self.sidecar = read_sidecar(self.path)
        try:
            with warnings.catch_warnings():
                # torch 2.13 marks TorchScript deprecated; the format is our artifact contract.
                warnings.simplefilter("ignore", DeprecationWarning)
                self._module = torch.jit.load(str(self.path), map_location="cpu")
        except (RuntimeError, ValueError) as exc:
            raise InputError(f"not a TorchScript module ({exc})", file=self.path) from exc
        self._module.eval()
        self._torch = torch
        self.n_actions = int(self.sidecar["n_actions"])
        self.hidden_size = int(self.sidecar["hidden_size"])
        self.name = f"torchscript:{self.path.name}"
        self._hidden: Any = None

    def reset(self, seed: int) -> None:
        self._hidden = None

    def logits(self, view: WindowView) -> np.ndarray:
        torch = self._torch
        a = view.depots.candidates.shape[1]
        if a != self.n_actions:
            raise InputError(
                f"the policy expects {self.n_actions} actions per depot, "
                f"the depots offer {a}; segment with --actions {self.n_actions}",
                file=self.path,
            )
        obs = observe(view)
        assert obs.shape[1] == obs_dim(a)
        if self._hidden is None or self._hidden.shape[0] != obs.shape[0]:
            self._hidden = torch.zeros((obs.shape[0], self.hidden_size), dtype=torch.float32)
        with torch.no_grad():
            out, self._hidden = self._module(torch.from_numpy(obs), self._hidden)
        logits = out.numpy().astype(np.float64)
        logits[~self.mask(view)] = -np.inf
        return logits

    def mask(self, view: WindowView) -> np.ndarray:
        """``(U, n_logits)`` True where the action exists."""
        return view.action_mask()

    def act(self, view: WindowView) -> np.ndarray:
        return np.argmax(self.logits(view), axis=1).astype(np.int64)
