"""Flight-range policies: the protocol, baselines, landing rules, observation, the actor
network and the loader of trained actor files."""

from .base import Policy, WindowView
from .baselines import GlobalPolicy, GreedyPolicy, MyopicPolicy, RandomPolicy, StayPolicy
from .observation import OBS_VERSION, ObsVersion, obs_dim, observe
from .registry import PolicySpec, make_policy
from .rules import BacklogPolicy, BatteryPolicy, FlowPolicy, RebalancePolicy

__all__ = [
    "OBS_VERSION",
    "BacklogPolicy",
    "BatteryPolicy",
    "FlowPolicy",
    "GlobalPolicy",
    "GreedyPolicy",
    "MyopicPolicy",
    "ObsVersion",
    "Policy",
    "PolicySpec",
    "RandomPolicy",
    "RebalancePolicy",
    "StayPolicy",
    "WindowView",
    "make_policy",
    "obs_dim",
    "observe",
]
