"""Day simulation: state, replay loop, metrics (docs/method.md §5, §8)."""

from .metrics import day_metrics, gini
from .replay import FlownDay, fly_day
from .state import DayState, default_fleet

__all__ = ["FlownDay", "DayState", "day_metrics", "default_fleet", "gini", "fly_day"]
