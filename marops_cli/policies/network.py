"""The recurrent actor network of every trained actor (paper §IV-D, §V-A: 64 units, tanh).

obs → Linear(hidden) → tanh → GRUCell(hidden) → Linear → logits, shared by every drone
(parameter sharing). Its ``forward(obs, hidden) -> (logits, hidden)`` is the contract of
the exported actor (docs/method.md §6). It lives in the policies layer, below training, because
loading an actor rebuilds this network from its weights file without running any code of
the file (:mod:`.weights`).
"""

from __future__ import annotations

import math

import torch
from torch import nn


def init_layer(layer: nn.Linear, gain: float) -> nn.Linear:
    """Orthogonal weights and zero biases (cleanrl): small policy logits at the start."""
    nn.init.orthogonal_(layer.weight, gain)
    nn.init.zeros_(layer.bias)
    return layer


class Actor(nn.Module):
    """Recurrent actor; ``forward(obs (B, D), hidden (B, H)) -> (logits (B, A), hidden)``."""

    def __init__(self, obs_dim: int, n_logits: int, hidden_size: int = 64) -> None:
        super().__init__()
        self.hidden_size = hidden_size
        self.encoder = init_layer(nn.Linear(obs_dim, hidden_size), math.sqrt(2.0))
        self.gru = nn.GRUCell(hidden_size, hidden_size)
        self.head = init_layer(nn.Linear(hidden_size, n_logits), 0.01)

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


def actor_shapes(obs_dim: int, n_logits: int, hidden_size: int) -> dict[str, tuple[int, ...]]:
    """Every tensor of :class:`Actor`'s state dict and its shape (what a weights file holds)."""
    h3 = 3 * hidden_size
    return {
        "encoder.weight": (hidden_size, obs_dim),
        "encoder.bias": (hidden_size,),
        "gru.weight_ih": (h3, hidden_size),
        "gru.weight_hh": (h3, hidden_size),
        "gru.bias_ih": (h3,),
        "gru.bias_hh": (h3,),
        "head.weight": (n_logits, hidden_size),
        "head.bias": (n_logits,),
    }
