"""HiGHS as the planner uses it: quiet, on one thread, and run so that another solver
object in the process cannot make it refuse (docs/decisions.md, "Planning a window")."""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys

import highspy

__all__ = ["new_highs", "run_highs", "silence_highs_banner"]


_banner_silenced = False


def silence_highs_banner() -> None:
    """HiGHS (1.16) prints a banner on stdout when its first solver object is made, which
    would corrupt ``--json`` output and cron logs: make that first one with stdout
    pointed at /dev/null, once, before the first solve (not on import: importing the
    library touches no file descriptor). Later objects print nothing (their output_flag
    is off)."""
    global _banner_silenced
    if _banner_silenced:
        return
    _banner_silenced = True
    try:
        sys.stdout.flush()
        saved = os.dup(1)
    except (OSError, ValueError, AttributeError):
        highspy.Highs()  # no file descriptor 1 to protect
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        highspy.Highs()
        with contextlib.suppress(OSError, AttributeError):
            ctypes.CDLL(None).fflush(None)  # what C++ buffered goes to /dev/null too
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def new_highs() -> highspy.Highs:
    """A quiet HiGHS solver object on one thread (the banner silenced first).

    The programs here are small (a few hundred columns): a second HiGHS worker finds
    nothing sooner and keeps polling for work, which doubles the CPU of a branch and
    bound for the same wall time and the same answer (docs/decisions.md, "Planning a
    window"). One thread also makes the search the same on any machine."""
    silence_highs_banner()
    h = highspy.Highs()
    h.setOptionValue("output_flag", False)
    h.setOptionValue("threads", 1)
    return h


def run_highs(h: highspy.Highs) -> None:
    """``h.run()``; when HiGHS' process-wide scheduler was started with more threads (by
    another solver object in this process, e.g. through cvxpy), HiGHS refuses a
    one-thread run: the scheduler is restarted and the run tried once more."""
    if h.run() == highspy.HighsStatus.kError and (
        h.getModelStatus() == highspy.HighsModelStatus.kNotset
    ):
        highspy.Highs.resetGlobalScheduler(True)
        h.run()
