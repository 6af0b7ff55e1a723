"""The days of a ``replay-day`` run as jobs that any process can run
(docs/decisions.md, "Workers").

A :class:`ReplayWork` holds what every day needs (each study area's replayed days'
rows, depots and fleet, the method); :meth:`ReplayWork.run` replays one (hub, day) and
returns its route tables, metrics and what the run reports of it, so that the files are
written by the process that runs the replay (marops_cli/app/replay_areas.py), whichever
worker or machine planned the day. A day does not depend on the days before it (the
policy starts each day from its seed), so a day planned on a worker is the same as one
planned in the replay's own process.
"""

from __future__ import annotations

import datetime as dt
import io
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa

from ..data.table import DayRequests
from ..methods import Method, register
from ..plans.window import WindowPlan
from ..policies.base import Policy
from .fleet import Fleet
from .scenario import Scenario, method_policy, other_actor, replay, replay_modules, route_tables


@dataclass(frozen=True)
class DayJob:
    """One day of one study area (``area``: its key in :attr:`ReplayWork.areas`)."""

    index: int
    area: int
    day: dt.date


@dataclass(frozen=True)
class DayScope:
    """What a day's log line says: orders due, planned, and what was left out."""

    day: dt.date
    orders_due: int
    planned: int
    outside_area: int
    outside_hours: int

    @classmethod
    def of(cls, reqs: DayRequests) -> DayScope:
        return cls(reqs.day, reqs.orders_due, len(reqs), reqs.outside_area, reqs.outside_hours)


@dataclass
class DayOutput:
    """A replayed day: its metrics, route tables, scope and (with ``plot``) its PNGs: the
    routes map and the operations over the day."""

    metrics: dict[str, Any]
    stops: pa.Table
    routes: pa.Table
    scope: DayScope
    png: bytes | None = None
    ops_png: bytes | None = None


def only_days(scn: Scenario, days: list[dt.date]) -> Scenario:
    """``scn`` with only the rows of ``days``: what a worker needs, not the whole file."""
    keep = np.isin(scn.table.delivery_day, np.array(days, dtype="datetime64[D]"))
    return Scenario(
        scn.table.subset(keep), scn.frame, scn.depots, scn.cfg, scn.history_days, scn.hub
    )


@dataclass
class ReplayWork:
    """Every day job of a ``replay-day`` run (a :class:`~marops_cli.workers.Work`)."""

    areas: dict[int, tuple[Scenario, Fleet]]
    method: str
    policy: str | None
    seed: int
    plot: bool
    spec: Method
    """The method's registry entry, so a worker knows a method registered at run time."""
    actor_sha: str | None = None
    """SHA-256 of the trained actor the command resolved (None: the method runs none)."""
    _policy: Policy | None = field(default=None, repr=False, compare=False)

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_policy": None}  # each process builds its own

    @property
    def preload(self) -> tuple[str, ...]:
        return replay_modules(actor=self.actor_sha is not None)

    def setup(self) -> None:
        register(self.spec)
        self._policy = None

    def use_policy(self, policy: Policy) -> None:
        """Fly ``policy`` (one this process loaded already) instead of building one."""
        self._policy = policy

    def _pol(self) -> Policy:
        if self._policy is None:
            # --trust-actor, carried in every area's config (one run, one choice).
            trust = any(scn.cfg.sim.trust_actor for scn, _ in self.areas.values())
            ops = next((scn.cfg.ops for scn, _ in self.areas.values()), None)
            self._policy = method_policy(self.method, self.policy, self.seed, trust=trust, ops=ops)
        return self._policy

    def run(self, job: DayJob, on_window: Callable[[WindowPlan], None] | None = None) -> DayOutput:
        scn, fleet = self.areas[job.area]
        res, reqs, metrics = replay(scn, job.day, fleet, self._pol(), self.method, on_window)
        stops, routes = route_tables(scn, reqs, res.plans, fleet, self.method)
        scope = DayScope.of(reqs)
        png = ops_png = None
        if self.plot:
            from .plot import plot_day, plot_operations

            # matplotlib writes the same PNG bytes to a buffer
            buf, ops_buf = io.BytesIO(), io.BytesIO()
            plot_day(res, reqs, buf)  # type: ignore[arg-type]
            plot_operations(res, reqs, ops_buf)  # type: ignore[arg-type]
            png, ops_png = buf.getvalue(), ops_buf.getvalue()
        return DayOutput(metrics, stops, routes, scope, png, ops_png)

    def refuse(self) -> str | None:
        """Why this machine would not run the actor the command resolved, or None."""
        if self.actor_sha is None:
            return None
        return other_actor(self.method, self._pol(), self.actor_sha)
