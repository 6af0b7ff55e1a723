"""Actor and critic networks of MAPPO (paper §IV-D, §V-A: recurrent, 64 units, tanh).

* :class:`Actor` (defined in marops_cli/policies/network.py, where loading an actor
  rebuilds it): shared by every drone (parameter sharing). obs → Linear(64) → tanh →
  GRUCell(64) → Linear → logits. Its ``forward(obs, hidden) -> (logits, hidden)`` is
  exactly the contract of the actor the CLI loads (docs/method.md §6).
* :class:`Critic`: centralised. It sees drone u's observation and the mean and
  max of every drone's observation (the fleet's state, whatever its size) and
  returns V_u. Feed-forward: the fleet summary plus time of day describes the
  state well enough, and a critic is never exported.
"""

from __future__ import annotations

import math

import torch
from torch import nn

from ..policies.network import Actor, init_layer

__all__ = ["Actor", "Critic", "fleet_input"]


def fleet_input(obs: torch.Tensor) -> torch.Tensor:
    """Critic input ``(..., U, 3D)``: own obs, fleet mean, fleet max (over the U axis, -2)."""
    mean = obs.mean(dim=-2, keepdim=True).expand_as(obs)
    top = obs.amax(dim=-2, keepdim=True).expand_as(obs)
    return torch.cat([obs, mean, top], dim=-1)


class Critic(nn.Module):
    """Centralised value V_u(s): MLP 3D → 64 → 64 → 1, tanh."""

    def __init__(self, obs_dim: int, hidden_size: int = 64) -> None:
        super().__init__()
        self.net = nn.Sequential(
            init_layer(nn.Linear(3 * obs_dim, hidden_size), math.sqrt(2.0)),
            nn.Tanh(),
            init_layer(nn.Linear(hidden_size, hidden_size), math.sqrt(2.0)),
            nn.Tanh(),
            init_layer(nn.Linear(hidden_size, 1), 1.0),
        )

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        """``obs (..., U, D)`` -> values ``(..., U)``."""
        return self.net(fleet_input(obs)).squeeze(-1)
