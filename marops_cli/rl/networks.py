"""Actor and critic networks of MAPPO (paper §IV-D, §V-A: recurrent, 64 units, tanh).

* :class:`Actor`: shared by every drone (parameter sharing). obs → Linear(64) →
  tanh → GRUCell(64) → Linear → logits. Its ``forward(obs, hidden) -> (logits,
  hidden)`` is exactly the TorchScript contract the CLI loads (docs/method.md §6).
* :class:`Critic`: centralised. It sees drone u's observation and the mean and
  max of every drone's observation (the fleet's state, whatever its size) and
  returns V_u. Feed-forward: the fleet summary plus time of day describes the
  state well enough, and a critic is never exported.
"""

from __future__ import annotations

import math

import torch
from torch import nn


def _init(layer: nn.Linear, gain: float) -> nn.Linear:
    # Orthogonal weights and zero biases (cleanrl): small policy logits at the start.
    nn.init.orthogonal_(layer.weight, gain)
    nn.init.zeros_(layer.bias)
    return layer


class Actor(nn.Module):
    """Recurrent actor; ``forward(obs (B, D), hidden (B, H)) -> (logits (B, A), hidden)``."""

    def __init__(self, obs_dim: int, n_logits: int, hidden_size: int = 64) -> None:
        super().__init__()
        self.hidden_size = hidden_size
        self.encoder = _init(nn.Linear(obs_dim, hidden_size), math.sqrt(2.0))
        self.gru = nn.GRUCell(hidden_size, hidden_size)
        self.head = _init(nn.Linear(hidden_size, n_logits), 0.01)

    def forward(self, obs: torch.Tensor, hidden: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = torch.tanh(self.encoder(obs))
        h = self.gru(x, hidden)
        return self.head(h), h

    def unroll(self, obs: torch.Tensor) -> torch.Tensor:
        """Logits ``(T, B, A)`` of whole episodes ``obs (T, B, D)`` from a zero hidden state."""
        h = torch.zeros(obs.shape[1], self.hidden_size, dtype=obs.dtype)
        out = []
        for t in range(obs.shape[0]):
            logits, h = self.forward(obs[t], h)
            out.append(logits)
        return torch.stack(out)


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
            _init(nn.Linear(3 * obs_dim, hidden_size), math.sqrt(2.0)),
            nn.Tanh(),
            _init(nn.Linear(hidden_size, hidden_size), math.sqrt(2.0)),
            nn.Tanh(),
            _init(nn.Linear(hidden_size, 1), 1.0),
        )

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        """``obs (..., U, D)`` -> values ``(..., U)``."""
        return self.net(fleet_input(obs)).squeeze(-1)
