"""Hyperparameters of MAPPO training (paper §IV-D, §V-A), one documented model."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from ..config import MAX_EPISODES, MAX_SEED
from ..workers.pool import MAX_WORKERS

MAX_ES_WEIGHT = 1000.0
"""The most ``es_energy_weight`` and ``es_loss_weight`` take: far above any weight that
shapes training (1 to 5), and a weight near the largest float made the costs infinite,
which no checkpoint or sidecar can hold."""


class TrainConfig(BaseModel):
    """Everything that shapes a training run besides the planner config.

    Paper values where the paper gives one (γ, clip, minibatch, GRU 64 tanh);
    the rest are cleanrl's PPO defaults or were tuned on synthetic data
    (``policies/README.md``).
    """

    model_config = ConfigDict(extra="forbid", validate_assignment=True, allow_inf_nan=False)

    algorithm: Literal["ppo", "es"] = Field(
        "ppo",
        description="ppo: the recurrent actor by multi-agent PPO (paper); es: the landing "
        "actor by evolution strategies on the day objective (an operating model's actor, "
        "docs/method.md §6.1)",
    )
    method: Literal["marops", "mappo"] = Field(
        "marops", description="marops: actions pick a destination; mappo: destination × plan slot"
    )
    episodes: int = Field(
        2000, ge=1, le=MAX_EPISODES, description="training episodes (one episode = one day)"
    )
    seed: int = Field(0, ge=0, le=MAX_SEED, description="seed of every random stream of the run")
    workers: int = Field(
        2, ge=1, le=MAX_WORKERS, description="rollout processes (results do not depend on it)"
    )
    episodes_per_update: int = Field(8, ge=1, description="episodes gathered per PPO update")
    hidden_size: int = Field(64, ge=1, description="GRU units of the actor (paper: 64)")
    critic_hidden: int = Field(
        64, ge=1, description="units of each critic hidden layer (paper: 64)"
    )
    gamma: float = Field(0.95, gt=0, le=1, description="discount factor γ (paper: 0.95)")
    gae_lambda: float = Field(0.95, ge=0, le=1, description="GAE λ (1 = Monte-Carlo returns)")
    clip: float = Field(0.2, gt=0, description="PPO clip ε of the surrogate (paper: 0.2)")
    minibatch: int = Field(
        64, ge=1, description="transitions per minibatch, H (paper: 64), as whole day sequences"
    )
    update_epochs: int = Field(4, ge=1, description="passes over each batch per update")
    lr: float = Field(3e-4, gt=0, description="Adam learning rate of actor and critic")
    anneal_lr: bool = Field(True, description="decay the learning rate linearly to 0")
    ent_coef: float = Field(0.03, ge=0, description="weight of the entropy bonus")
    vf_coef: float = Field(0.5, ge=0, description="weight of the critic loss")
    max_grad_norm: float = Field(0.5, gt=0, description="global gradient-norm clip")
    norm_adv: bool = Field(True, description="normalise advantages per minibatch")
    reward_scope: Literal["credit", "team", "observed"] = Field(
        "credit",
        description="D_u of eq. (10): map delay split by what u spared, evenly, or u's areas",
    )
    energy_scope: Literal["own", "team"] = Field(
        "own", description="E_u of eq. (10): u's own flight energy or the fleet's mean"
    )
    delay_scale_h: float = Field(20.0, gt=0, description="s_D: D_u (h) at which σ̃ reaches 0.5")
    energy_scale_kj: float = Field(500.0, gt=0, description="s_E: E_u (kJ) at which σ̃ reaches 0.5")
    bc_coef: float = Field(
        1.0,
        ge=0,
        description="weight of the imitation term: cross-entropy against bc_teacher's "
        "choice on the visited states; marops only",
    )
    bc_teacher: Literal["myopic", "free"] = Field(
        "free",
        description="target of the imitation term: the one-window best response (myopic, "
        "free landing included), or always the free landing (the whole-map rule)",
    )
    bc_anneal: float = Field(
        0.1,
        ge=0,
        le=1,
        description="fraction of the episodes over which the imitation weight falls to 0",
    )
    keep_best: bool = Field(
        True,
        description="export the actor of the held-out evaluation with the lowest daily "
        "combined cost (early stopping) instead of the last one",
    )
    alpha_range: tuple[float, float] | None = Field(
        (0.1, 0.9),
        description="marops: each episode flies at an α drawn uniformly from this range (α is "
        "an input of the actor, so one actor serves every α); None: the config's α only",
    )
    eval_days_per_scenario: int = Field(
        0, ge=0, description="held-out days per scenario in training evaluations (0: all)"
    )
    plan_slots: int = Field(4, ge=2, description="mappo: plan slots per destination (last = empty)")
    obs_version: Literal[4, 5] = Field(
        4,
        description="marops: observation version (docs/method.md §6): 4, or 5 adding the "
        "drone's own type (payload, battery, speed) for mixed fleets",
    )
    es_sigma: float = Field(
        0.3, gt=0, description="es: standard deviation of each weight's perturbation"
    )
    es_step: float = Field(0.2, gt=0, description="es: step size of each generation's move")
    es_pairs: int = Field(6, ge=1, description="es: antithetic pairs of weights per generation")
    es_days: int = Field(4, ge=1, description="es: training days each generation replays")
    es_energy_weight: float = Field(
        1.0,
        ge=0,
        le=MAX_ES_WEIGHT,
        description="es: cost of each share of energy per drone above the day's best rule's "
        "(beyond es_energy_slack)",
    )
    es_energy_slack: float = Field(
        0.0,
        ge=0,
        le=1,
        description="es: share of energy per drone above the day's best rule's that costs "
        "nothing (the hinge of the energy penalty)",
    )
    es_energy_basis: Literal["drone", "parcel"] = Field(
        "drone",
        description="es: the energy es_energy_weight prices: per drone, or per delivered "
        "parcel (so delivering more for the same energy per parcel costs nothing)",
    )
    landing_features: Literal["basic", "context", "rules"] = Field(
        "basic",
        description="es: the landing actor's features: basic (16 weights, format /2), "
        "context (22 weights, format /3: fleet density, load, stranding and α as well), or "
        "rules (25 weights, format /4: the flow rule's landings as well)",
    )
    landing_start: list[float] | None = Field(
        None,
        description="es: the weights training starts from (another landing actor's, "
        "extended with zeros; --init); None: the backlog score",
    )
    landing_train: Literal["all", "new"] = Field(
        "all",
        description="es: the weights training moves: all, or only those of the features "
        "landing_start's actor lacks (its own stay as they are)",
    )
    es_loss_weight: float = Field(
        2.0,
        ge=0,
        le=MAX_ES_WEIGHT,
        description="es: cost of each share of J above the day's best rule's, on top of the "
        "share itself (so a day lost weighs more than a day won)",
    )
    es_rules: list[str] | None = Field(
        None,
        description="es: the rules a day's best rule is chosen from (names of the reference "
        "rules, marops_cli/methods.py); None: every reference rule",
    )
    eval_every: int = Field(200, ge=1, description="episodes between held-out evaluations")
    checkpoint_every: int = Field(40, ge=1, description="episodes between checkpoints")

    @field_validator("es_rules")
    @classmethod
    def _es_rules(cls, v: list[str] | None) -> list[str] | None:
        from ..methods import reference_rules  # deferred: the registry loads the policies

        known = reference_rules()
        if v is not None and (not v or any(r not in known for r in v) or len(set(v)) < len(v)):
            raise ValueError(f"expected distinct names of {', '.join(known)}")
        return v

    @field_validator("alpha_range")
    @classmethod
    def _alpha_range(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and not 0.001 <= v[0] <= v[1] <= 1:
            raise ValueError("expected 0.001 <= low <= high <= 1 (docs/config.md, plan.alpha)")
        return v
