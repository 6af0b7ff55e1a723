"""One drive for every recurrent actor (docs/method.md §6): greedy actions of any module
``module(obs, hidden) -> (logits, hidden)``.

Training evaluations fly the in-memory actor through it and ``replay-day`` the exported
TorchScript file (:class:`~.torchscript.TorchScriptPolicy`), so both take the same
actions on the same window. Observation version 2: all drones at once; later versions
drone by drone, each seeing what the drones before it claimed
(:class:`~.observation.SequentialObserver`), priced with the run's planner settings.
With plan slots (the MAPPO baseline) the choice is destination × slot: :meth:`act` returns
the slots with the actions (:class:`~.base.SlotActions`) and :attr:`selector` (a
:class:`~.direct.SlotSelector`) flies them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from ..errors import RunError
from .base import SLOT_PLANNER, PolicyBase, SlotActions, WindowView
from .observation import ObsVersion, choice_mask, observe, observe_and_choose, to_actions

if TYPE_CHECKING:
    from ..config import PlannerConfig

__all__ = ["RecurrentPolicy"]


class RecurrentPolicy(PolicyBase):
    """Arg-max actions of a recurrent actor; its hidden state lives for one day."""

    scope: Literal["range", "global"] = "range"

    def __init__(
        self,
        module: Callable[[Any, Any], tuple[Any, Any]],
        n_actions: int,
        hidden_size: int,
        version: int,
        *,
        n_slots: int = 1,
        selector: Any = None,
        name: str = "actor",
    ) -> None:
        import torch  # deferred: importing torch costs a second the other policies never pay

        self._torch = torch
        self._module = module
        self.n_actions = int(n_actions)
        self.hidden_size = int(hidden_size)
        self.obs_version = ObsVersion(int(version))
        self.n_slots = int(n_slots)
        self.selector = selector
        if self.n_slots > 1:
            self.planner = SLOT_PLANNER  # its slots rank the paper's subset plans
        self.name = name
        self._hidden: Any = None
        self._model: Any = None
        self._plan: Any = None

    def configure(self, cfg: PlannerConfig) -> None:
        """Price observations (version 3 on) with the run's energy model and plan settings."""
        from ..energy import EnergyModel

        self._model, self._plan = EnergyModel.of(cfg.energy), cfg.plan

    def reset(self, seed: int) -> None:
        self._hidden = None

    def _check(self, view: WindowView) -> None:
        """Raise when the view does not suit the actor (the file-backed policy names its file)."""
        return

    def _start(self, view: WindowView) -> None:
        self._check(view)
        if self._hidden is None or self._hidden.shape[0] != view.n_drones:
            self._hidden = self._torch.zeros(
                (view.n_drones, self.hidden_size), dtype=self._torch.float32
            )

    def _forward(self, drones: np.ndarray, obs: np.ndarray) -> np.ndarray:
        """Logits of ``drones`` from their observations; advances their hidden states."""
        torch = self._torch
        idx = torch.from_numpy(np.asarray(drones, dtype=np.int64))
        with torch.no_grad():
            out, h = self._module(torch.from_numpy(obs), self._hidden[idx])
        self._hidden[idx] = h
        logits = out.numpy().astype(np.float64)
        if not np.isfinite(logits).all():
            raise RunError(f"{self.identity}: the actor returned NaN or infinite logits")
        return logits

    def mask(self, view: WindowView) -> np.ndarray:
        """``(U, n_logits)`` True where the choice exists (version 4 on: the free landing,
        last), every plan slot of it."""
        return np.repeat(choice_mask(view, self.obs_version), self.n_slots, axis=1)

    def logits(self, view: WindowView) -> np.ndarray:
        """Version-2 logits of every drone at once, impossible choices at −∞."""
        assert self.obs_version == ObsVersion.MAPPO, "later versions choose drone by drone (act)"
        self._start(view)
        logits = self._forward(np.arange(view.n_drones), observe(view))
        logits[~self.mask(view)] = -np.inf
        return logits

    def act(self, view: WindowView) -> np.ndarray | SlotActions:
        self._start(view)
        mask = self.mask(view)

        def choose(drones: np.ndarray, obs: np.ndarray) -> np.ndarray:
            logits = self._forward(drones, obs)
            logits[~mask[drones]] = -np.inf
            return np.argmax(logits, axis=1)

        joint = observe_and_choose(
            view, choose, self.obs_version, model=self._model, plan=self._plan
        )[1]
        actions = to_actions(joint // self.n_slots, self.n_actions)
        if self.n_slots == 1:
            return actions
        return SlotActions(actions, joint % self.n_slots)
