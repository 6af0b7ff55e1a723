"""Requests no drone of the fleet can ever serve (docs/outputs.md, ``unservable_*``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..energy import EnergyModel

__all__ = ["unservable_masks"]


def unservable_masks(
    day: Any, depots_xy: np.ndarray, model: EnergyModel | Sequence[EnergyModel]
) -> tuple[np.ndarray, np.ndarray]:
    """``(heavy, far)``, True per request no drone can ever serve: heavier than every
    type's payload limit; too far: even alone, from the nearest depot and back to the
    nearest depot, over the usable battery of every type that can lift it."""
    from ..segment.depots import nearest_depot

    models = [model] if isinstance(model, EnergyModel) else list(model)
    d = nearest_depot(np.column_stack([day.x_m, day.y_m]), depots_xy)[1]
    heavy = np.ones(len(day.weight_kg), dtype=bool)
    reach = np.zeros(len(day.weight_kg), dtype=bool)
    for m in models:
        lifts = m.fits(day.weight_kg)
        w = np.minimum(day.weight_kg, m.max_payload_kg)
        alone = d * np.interp(w, m.grid_kg, m.table_j_per_m) + d * m.energy_per_m(0.0)
        heavy &= ~lifts
        reach |= lifts & (alone <= m.usable_j)
    return heavy, ~heavy & ~reach
