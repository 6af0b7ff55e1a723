"""Batteries, chargers and drones on long flights over one day (docs/method.md,
"Operating model").

Timing rules, one window at a time:

* At the start of window t a drone still on a long flight (``busy``) is busy; a drone
  without a battery takes a charged one from its depot's spares (drones in index order);
  one that finds none waits the window. Busy and waiting drones only stay.
* A drone whose route uses energy leaves its battery on charge at the depot it lands at,
  at the end of the window it lands in, and needs a charged one for its next flight; a
  drone that stays keeps its battery.
* Each depot's chargers charge the first batteries of its queue (first come, first
  charged), each by ``charge_power_w`` × the window length per window; a battery whose
  charge completes in window t is a spare from window t + 1.
* Under ``busy`` a route of flight time T keeps its drone for ⌈T / window⌉ windows.
"""

from __future__ import annotations

import math

import numpy as np

from ..config import OpsConfig

__all__ = ["BUSY", "WAITING", "Operations"]

_EPS = 1e-9
BUSY = 1  # a drone still on a long flight
WAITING = 2  # a drone waiting for a charged battery


class Operations:
    """The operating model's state of one day: spare charged batteries and charging queues
    per depot, and per drone its battery and the first window it can fly again."""

    def __init__(self, cfg: OpsConfig, n_depots: int, n_drones: int, n_windows: int) -> None:
        self.cfg = cfg
        self.limited = cfg.batteries_per_depot is not None
        self.charged = np.full(n_depots, cfg.batteries_per_depot or 0, dtype=np.int64)
        self.queue: list[list[float]] = [[] for _ in range(n_depots)]
        """Per depot, the joules each battery on charge still needs, first come first."""
        self.landing: list[tuple[int, int, float]] = []
        """Used batteries on their way: (window the drone lands in, depot, joules used)."""
        self.has_battery = np.ones(n_drones, dtype=bool)  # each drone starts charged
        self.busy_until = np.zeros(n_drones, dtype=np.int64)  # first window it can fly
        self.battery_waits = 0
        self.busy_windows = 0
        self.charged_w = np.zeros((n_windows, n_depots), dtype=np.int64)
        """Spare charged batteries per depot after each window's swaps."""
        self.held_w = np.zeros((n_windows, n_drones), dtype=np.int8)
        """Per window and drone, why it could not fly: 0 it could, ``BUSY`` on a long
        flight, ``WAITING`` for a charged battery."""
        self._flying = np.ones(n_drones, dtype=bool)

    def ready(self, t: int, drone_depot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(ready, swap)`` at the start of window ``t``: the drones that can fly, and
        those that take a charged battery first. Nothing changes."""
        free = self.busy_until <= t
        swap = free & ~self.has_battery
        if self.limited:
            left = self.charged.copy()
            for u in np.flatnonzero(swap):
                d = int(drone_depot[u])
                if left[d] > 0:
                    left[d] -= 1
                else:
                    swap[u] = False
        return free & (self.has_battery | swap), swap

    def start_window(self, t: int, drone_depot: np.ndarray) -> None:
        """Swap batteries at the start of window ``t`` and count the drones held back."""
        ready, swap = self.ready(t, drone_depot)
        free = self.busy_until <= t
        self.busy_windows += int((~free).sum())
        self.battery_waits += int((free & ~ready).sum())
        for u in np.flatnonzero(swap):
            if self.limited:
                self.charged[int(drone_depot[u])] -= 1
            self.has_battery[u] = True
        if t < self.charged_w.shape[0]:
            self.charged_w[t] = self.charged
            self.held_w[t] = np.where(~free, BUSY, np.where(ready, 0, WAITING))
        self._flying = ready

    def fly(self, t: int, drone: int, end: int, energy_j: float, span_windows: float) -> None:
        """Drone ``drone`` flies a route of ``energy_j`` lasting ``span_windows`` windows
        from window ``t``, landing at depot ``end``."""
        if energy_j <= 0:
            return  # it stayed: its battery stays charged
        if not self._flying[drone]:
            raise RuntimeError(f"drone {drone} flew in window {t} though it could not")
        k = max(1, math.ceil(span_windows - _EPS)) if self.cfg.busy else 1
        self.busy_until[drone] = t + k
        self.has_battery[drone] = False
        self.landing.append((t + k - 1, int(end), float(energy_j)))

    def end_window(self, t: int, window_s: float) -> None:
        """Charge over window ``t``; batteries landed in it join their depot's queue."""
        landed = [x for x in self.landing if x[0] <= t]
        self.landing = [x for x in self.landing if x[0] > t]
        if not self.limited:
            return
        step = self.cfg.charge_power_w * window_s
        k = self.cfg.chargers_per_depot
        for d, q in enumerate(self.queue):
            head = [e - step for e in q[:k]]
            self.charged[d] += sum(e <= _EPS for e in head)
            self.queue[d] = [e for e in head if e > _EPS] + q[k:]
        for _, d, e in landed:
            self.queue[d].append(e)

    def charging(self) -> np.ndarray:
        """``(N,)`` batteries on charge or waiting for a charger per depot (those landing
        in a later window not yet among them)."""
        return np.array([len(q) for q in self.queue], dtype=np.int64)

    def charged_min(self) -> int | None:
        """The fewest spare charged batteries over all depots after any window's swaps;
        None with unlimited swaps."""
        if not self.limited or self.charged_w.shape[0] == 0:
            return None
        return int(self.charged_w.sum(axis=1).min())
