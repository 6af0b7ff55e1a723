"""The drone energy model (docs/method.md §3, paper eqs. 4–9, after Stolaroff et al. 2018).

Power depends on the payload on board only, so :class:`EnergyModel` solves the
induced-velocity equation once on a fine payload grid and interpolates linearly
afterwards; :func:`reference_power_w` solves it directly and exists for tests.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .config import EnergyConfig

__all__ = [
    "ENERGY_TOL_J",
    "MAX_TABLE_ENTRIES",
    "PAYLOAD_TOL_KG",
    "EnergyModel",
    "power_curve_w",
    "reference_power_w",
    "table_steps",
]

PAYLOAD_TOL_KG = 1e-9
"""A load fits the payload limit up to this much over it: sums of the same parcel weights
in another order differ by rounding (docs/method.md, "Feasibility")."""
ENERGY_TOL_J = 1e-6
"""A route fits the usable battery up to this much over it: the same route's energy summed
leg by leg, or by insertions, differs by rounding; a search that adds energies up
insertion by insertion plans this much under the battery so that its routes, recomputed,
still fit (docs/method.md, "Feasibility")."""

MAX_TABLE_ENTRIES = 20_000_000
"""Payload-table entries a run's drone types may need together (about 0.5 GB): a type's
table has :func:`table_steps` + 1 entries, at most 5,000,001 (a 500 kg payload in steps
of 0.1 g), and each type of a fleet has its own, so a fleet file of hundreds of such
types would fill the memory before any window is planned."""

_NEWTON_MAX_ITER = 60
_NEWTON_RTOL = 1e-14


def _flight_terms(
    payload_kg: NDArray[np.float64], cfg: EnergyConfig
) -> tuple[NDArray[np.float64], ...]:
    """Thrust, pitch and the constant of the induced-velocity equation, per payload."""
    mass = cfg.body_kg + cfg.battery_kg + payload_kg  # eq. (5)
    weight = mass * cfg.g
    cda = cfg.cda_m2 + cfg.parcel_cda_m2 * payload_kg
    drag = 0.5 * cfg.air_density * cfg.speed_ms**2 * cda
    theta = np.arctan(drag / weight)
    thrust = weight * (1.0 + np.tan(theta))  # eq. (4), the paper's form (= W + D)
    # eq. (7) rearranged: v_hat * sqrt(a^2 + (b + v_hat)^2) = c
    c = 2.0 * thrust / (math.pi * cfg.rotor_diameter_m**2 * cfg.rotors * cfg.air_density)
    return thrust, theta, c


def _induced_velocity(
    theta: NDArray[np.float64], c: NDArray[np.float64], speed: float
) -> NDArray[np.float64]:
    """Solve eq. (7) for the induced velocity by vectorised Newton iteration.

    F(x) = x * sqrt(a^2 + (b + x)^2) - c is increasing and convex on x >= 0 (b >= 0), so
    Newton started from an upper bound of the root, min(sqrt(c), c / a), decreases
    monotonically onto it.
    """
    a = speed * np.cos(theta)
    b = speed * np.sin(theta)
    x = np.minimum(np.sqrt(c), c / np.maximum(a, 1e-300))
    for _ in range(_NEWTON_MAX_ITER):
        s = np.sqrt(a * a + (b + x) ** 2)
        step = (x * s - c) / (s + x * (b + x) / s)
        x = x - step
        if np.all(np.abs(step) <= _NEWTON_RTOL * np.abs(x)):
            break
    return x


def power_curve_w(payload_kg: ArrayLike, cfg: EnergyConfig | None = None) -> NDArray[np.float64]:
    """Steady-flight power (W) for each payload, solving eq. (7) exactly (vectorised)."""
    cfg = cfg or EnergyConfig()
    payload = np.asarray(payload_kg, dtype=np.float64)
    thrust, theta, c = _flight_terms(payload, cfg)
    v_hat = _induced_velocity(theta, c, cfg.speed_ms)
    return (cfg.speed_ms * np.sin(theta) + v_hat) * thrust / cfg.efficiency  # eq. (8)


def reference_power_w(payload_kg: float, cfg: EnergyConfig | None = None) -> float:
    """Power (W) with ``payload_kg`` on board, by bracketed root-finding: slow, for tests."""
    from scipy.optimize import brentq  # only the slow reference path needs scipy

    cfg = cfg or EnergyConfig()
    thrust, theta, c = (
        float(t) for t in _flight_terms(np.asarray(payload_kg, dtype=np.float64), cfg)
    )
    v = cfg.speed_ms
    a, b = v * math.cos(theta), v * math.sin(theta)

    def residual(x: float) -> float:  # eq. (7)
        return x - 2.0 * thrust / (
            math.pi
            * cfg.rotor_diameter_m**2
            * cfg.rotors
            * cfg.air_density
            * math.sqrt(a * a + (b + x) ** 2)
        )

    v_hat = brentq(residual, 0.0, math.sqrt(c) + 1.0, xtol=1e-14, rtol=1e-15)
    return (v * math.sin(theta) + v_hat) * thrust / cfg.efficiency  # eq. (8)


def table_steps(cfg: EnergyConfig) -> int:
    """Steps of the payload table of the drone parameters ``cfg`` (its entries: one more)."""
    # At least one step: a payload limit far below the step would otherwise make none.
    return max(1, int(math.ceil(cfg.max_payload_kg / cfg.table_step_kg - 1e-9)))


class EnergyModel:
    """Power by payload from a precomputed table; leg and route energies (eq. (9)).

    Payloads must lie in ``[0, max_payload_kg]``; anything outside raises ``ValueError``
    rather than extrapolating silently.
    """

    _built: ClassVar[dict[str, EnergyModel]] = {}  # one model per drone type, per process

    @classmethod
    def of(cls, cfg: EnergyConfig | None = None) -> EnergyModel:
        """The model of these drone parameters, built once per process and shared (the
        model is read-only: every method is a pure function of the tables)."""
        cfg = cfg or EnergyConfig()
        key = cfg.model_dump_json()
        model = cls._built.get(key)
        if model is None:
            model = cls._built[key] = cls(cfg.model_copy())
        return model

    def __init__(self, cfg: EnergyConfig | None = None) -> None:
        self.cfg = cfg or EnergyConfig()
        n = table_steps(self.cfg)
        self.grid_kg = np.linspace(0.0, self.cfg.max_payload_kg, n + 1)
        self.table_w = power_curve_w(self.grid_kg, self.cfg)
        self.table_j_per_m = self.table_w / self.cfg.speed_ms
        self._step = self.cfg.max_payload_kg / n

    @property
    def speed_ms(self) -> float:
        return self.cfg.speed_ms

    @property
    def usable_j(self) -> float:
        """Usable battery energy: capacity × (1 − reserve)."""
        return self.cfg.usable_j

    @property
    def max_payload_kg(self) -> float:
        return self.cfg.max_payload_kg

    def fits(
        self, weight_kg: ArrayLike = 0.0, energy_j: ArrayLike | None = None
    ) -> NDArray[np.bool_]:
        """Whether a load of ``weight_kg`` fits the payload limit and a route of
        ``energy_j`` (when given) the usable battery, each within its tolerance
        (:data:`PAYLOAD_TOL_KG`, :data:`ENERGY_TOL_J`); elementwise."""
        ok = np.asarray(weight_kg) <= self.max_payload_kg + PAYLOAD_TOL_KG
        if energy_j is not None:
            ok = ok & (np.asarray(energy_j) <= self.usable_j + ENERGY_TOL_J)
        return ok

    def _check(self, payload: NDArray[np.float64]) -> None:
        tol = PAYLOAD_TOL_KG
        if payload.size and (payload.min() < -tol or payload.max() > self.max_payload_kg + tol):
            raise ValueError(
                f"expected payload in [0, {self.max_payload_kg}] kg, "
                f"got {payload.min():.6g}..{payload.max():.6g}"
            )

    def power_w(self, payload_kg: ArrayLike) -> NDArray[np.float64]:
        """Power (W) in steady flight with ``payload_kg`` on board (eq. (8), interpolated)."""
        payload = np.asarray(payload_kg, dtype=np.float64)
        self._check(payload)
        return np.interp(payload, self.grid_kg, self.table_w)

    def energy_per_m(self, payload_kg: ArrayLike) -> NDArray[np.float64]:
        """Energy per metre flown (J/m) with ``payload_kg`` on board: P / v."""
        payload = np.asarray(payload_kg, dtype=np.float64)
        self._check(payload)
        return np.interp(payload, self.grid_kg, self.table_j_per_m)

    def leg_energy_j(self, distance_m: ArrayLike, payload_kg: ArrayLike) -> NDArray[np.float64]:
        """Energy (J) of legs of ``distance_m`` flown with ``payload_kg`` (eq. (9))."""
        return np.asarray(distance_m, dtype=np.float64) * self.energy_per_m(payload_kg)

    def max_range_m(self, payload_kg: float = 0.0) -> float:
        """Distance the usable battery flies with a constant payload."""
        return float(self.usable_j / self.energy_per_m(payload_kg))

    def route_energy(
        self, points_xy: ArrayLike, weights_kg: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Leg lengths (m) and leg energies (J) of a route.

        ``points_xy`` is ``(n + 2, 2)``: the start depot, the ``n`` customers in
        visiting order, the end depot. ``weights_kg`` holds the ``n`` parcel weights in
        the same order. The drone leaves with every parcel and drops one at each
        customer (eq. (6)), so leg ``i`` carries ``sum(weights_kg[i:])`` and the last
        leg is flown empty.
        """
        pts = np.asarray(points_xy, dtype=np.float64)
        w = np.asarray(weights_kg, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 2 or pts.shape[0] != w.size + 2:
            raise ValueError(
                f"expected {w.size + 2} points (start, customers, end), got shape {pts.shape}"
            )
        legs_m = np.hypot(*np.diff(pts, axis=0).T)
        on_board = np.append(np.cumsum(w[::-1])[::-1], 0.0)  # eq. (6)
        return legs_m, self.leg_energy_j(legs_m, on_board)
