"""The route pool's innermost loop, compiled (numba), with the same results to the bit.

The pool (:mod:`.pool`) spends most of its time pricing the insertion of every free
candidate into one route: a few dozen numpy operations on arrays of a hundred
elements, where numpy's per-call cost outweighs the arithmetic. The kernels
(:mod:`._jit`) do the same operations, in the same order, in one compiled loop: every
product, sum and comparison is the one numpy makes, so a plan is the same to the
byte with or without them (docs/decisions.md, "The route pool"), and the pool keeps
its numpy code (:mod:`.pool_pricing`) for where numba is missing or cannot compile.

Loading numba and the compiled code from its cache takes about 0.6 s of CPU (2 s the
first time, when it compiles), what the kernels save over five or six windows. So a
process plans its first :data:`NUMPY_POOLS` windows with numpy (a ``plan-window``) and
loads the kernels for the next (a day's replay); ``MAROPS_JIT=1`` loads them at the
first window (benchmarks), ``MAROPS_JIT=0`` never. The compiled code is cached
next to :mod:`._jit`, or in numba's cache directory when that is not writable.
"""

from __future__ import annotations

import os
from types import ModuleType

__all__ = ["JIT_ENV", "NUMPY_POOLS", "kernels", "kernels_now", "load_kernels"]

JIT_ENV = "MAROPS_JIT"
"""``1``: the kernels from the first window; ``0``: never; unset: after :data:`NUMPY_POOLS`."""
NUMPY_POOLS = 2
"""Route pools a process builds with numpy before it loads the kernels."""

_pools = 0
_loaded: ModuleType | None = None
_tried = False


def kernels() -> ModuleType | None:
    """The kernels for the route pool being built (one call per pool), or None: numpy."""
    global _pools
    mode = os.environ.get(JIT_ENV, "").strip()
    if mode == "0":
        return None
    _pools += 1
    if mode != "1" and _pools <= NUMPY_POOLS and not _tried:
        return None
    return load_kernels()


def kernels_now() -> ModuleType | None:
    """The kernels loaded now, before any pool (a worker about to run timed jobs), or
    None when ``MAROPS_JIT=0`` turns them off or they cannot load."""
    return None if os.environ.get(JIT_ENV, "").strip() == "0" else load_kernels()


def load_kernels() -> ModuleType | None:
    """The compiled kernels, loaded and checked now (once per process), or None when
    numba is missing or fails to compile them."""
    global _loaded, _tried
    if not _tried:
        _tried = True
        try:
            from . import _jit

            _jit.warm_up()
        except Exception:  # no numba, or no compiler for this machine: numpy it is
            _loaded = None
        else:
            _loaded = _jit
    return _loaded
