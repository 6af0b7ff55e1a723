"""Policies that need no training: stay, random, greedy, global (docs/method.md §7), myopic."""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

import numpy as np

from .base import PolicyBase, WindowView

if TYPE_CHECKING:
    from ..config import PlannerConfig


class StayPolicy(PolicyBase):
    """Every drone comes back to the depot it left (action 0)."""

    name = "stay"
    scope: Literal["range", "global"] = "range"

    def reset(self, seed: int) -> None:
        pass

    def act(self, view: WindowView) -> np.ndarray:
        return np.zeros(view.n_drones, dtype=np.int64)


class RandomPolicy(PolicyBase):
    """A uniformly random candidate per drone (the paper's OPS-random), seeded."""

    name = "random"
    scope: Literal["range", "global"] = "range"

    def __init__(self, seed: int = 0) -> None:
        self._rng = np.random.default_rng(seed)

    def reset(self, seed: int) -> None:
        self._rng = np.random.default_rng(seed)

    def act(self, view: WindowView) -> np.ndarray:
        mask = view.action_mask()
        out = np.zeros(view.n_drones, dtype=np.int64)
        for u in range(view.n_drones):
            out[u] = self._rng.choice(np.flatnonzero(mask[u]))
        return out


class GreedyPolicy(PolicyBase):
    """Fly towards the most waiting delay per metre (a cheap baseline an analyst tries first).

    Score of action a from depot s with destination d: (summed delay of the pending
    requests in d's service area + a small weight per pending request, so work
    beats an empty area before anything is late) / (distance s→d + L), where L is
    the median spacing between neighbouring depots (so staying is not free of
    cost). Ties go to the lower action index (stay first).
    """

    name = "greedy"
    scope: Literal["range", "global"] = "range"

    def __init__(self, pending_weight_h: float = 0.05) -> None:
        self.pending_weight_h = pending_weight_h

    def reset(self, seed: int) -> None:
        pass

    def act(self, view: WindowView) -> np.ndarray:
        dep = view.depots
        n = len(dep)
        out = np.zeros(view.n_drones, dtype=np.int64)
        if view.pending_xy.shape[0] == 0 or n < 2:
            return out
        value = np.bincount(
            view.pending_area, weights=view.pending_delay_h + self.pending_weight_h, minlength=n
        )
        d = np.hypot(
            dep.xy[:, None, 0] - dep.xy[None, :, 0], dep.xy[:, None, 1] - dep.xy[None, :, 1]
        )
        spacing = float(np.median(np.sort(d, axis=1)[:, 1]))
        for u, s in enumerate(view.drone_depot):
            dests = dep.candidates[int(s)]
            score = value[dests] / (d[int(s), dests] + spacing)
            out[u] = int(np.argmax(score))  # first maximum: lower action index on ties
        return out


class GlobalPolicy(StayPolicy):
    """Whole-map planning (OPS-global): no flight range; the planner picks destinations,
    so every drone's action is stay, as :class:`StayPolicy`'s."""

    name = "global"
    scope: Literal["range", "global"] = "global"


class MyopicPolicy(PolicyBase):
    """One-window best response: drones in turn take the destination whose best plan is
    worth most now (λ Σ v − E, as the selection counts it), given what the drones before
    them claimed (:class:`~marops_cli.policies.observation.SequentialObserver`).

    It looks one window ahead only; the learned actor starts from it and learns when
    repositioning pays later ("slower is faster").
    """

    name = "myopic"
    scope: Literal["range", "global"] = "range"

    def __init__(self) -> None:
        from ..config import PlannerConfig

        self.configure(PlannerConfig())

    def configure(self, cfg: PlannerConfig) -> None:
        """Use the run's energy model and planning settings (α, M̂, payload)."""
        from ..energy import EnergyModel

        self._model, self._plan = EnergyModel.of(cfg.energy), cfg.plan

    def reset(self, seed: int) -> None:
        pass

    def act(self, view: WindowView) -> np.ndarray:
        from .observation import ObsVersion, best_value_action, observe_and_choose

        mask = view.action_mask()
        return observe_and_choose(
            view,
            lambda u, obs: best_value_action(obs, mask[u]),
            ObsVersion.SEQUENTIAL,
            model=self._model,
            plan=self._plan,
        )[1]
