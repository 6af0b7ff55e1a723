"""marops: operations planner for drone last-mile delivery (the MAR-OPS method)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("marops")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+local"

# The Python API (``from marops_cli import api``): the commands as functions. They are
# not re-exported here because ``marops_cli.segment`` and ``marops_cli.evaluate`` are
# subpackages, whose import would shadow functions of those names.
from . import api  # noqa: E402

__all__ = ["__version__", "api"]
