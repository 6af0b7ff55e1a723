"""marops: operations planner for drone last-mile delivery (the MAR-OPS method)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("marops")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+local"

__all__ = ["__version__"]
