"""Learning the flight range: multi-agent PPO with a shared recurrent actor (paper §IV-B,
§IV-D, Alg. 3; docs/method.md §6).

``env`` turns a day of the simulator into a multi-agent episode with the reward of
eq. (10); ``networks`` holds the GRU actor and the centralised critic; ``ppo`` the
GAE, the clipped loss and one update; ``rollout`` runs episodes in worker
processes; ``train`` is the resumable loop; ``export`` writes the TorchScript
actor and its sidecar. Nothing here is imported when a trained actor is used.
"""

from .config import TrainConfig
from .data import load_training_data, split_days
from .env import DeliveryEnv, reward, squash
from .evaluate import daily_combined_costs, method_table
from .export import write_actor
from .networks import Actor, Critic
from .ppo import gae, ppo_loss, ppo_update
from .train import Trainer, train_actor

__all__ = [
    "Actor",
    "Critic",
    "DeliveryEnv",
    "TrainConfig",
    "Trainer",
    "daily_combined_costs",
    "gae",
    "load_training_data",
    "method_table",
    "ppo_loss",
    "ppo_update",
    "reward",
    "split_days",
    "squash",
    "train_actor",
    "write_actor",
]
