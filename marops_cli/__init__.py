"""marops: operations planner for drone last-mile delivery (the MAR-OPS method)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("marops")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+local"

from .api import evaluate, plan_window, read_lade, replay_day, segment  # noqa: E402

__all__ = ["__version__", "evaluate", "plan_window", "read_lade", "replay_day", "segment"]
