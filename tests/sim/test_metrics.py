"""Day metrics: the requests no drone can serve."""

from __future__ import annotations

import numpy as np


def test_unservable_requests_by_hand() -> None:
    """Depot at (0, 0): a 1 kg parcel at 1 km is servable; a 2.5 kg parcel at 5 km is not
    (5 km at 29.426 kJ/km out and 15.991 back = 227.1 kJ > 168.75 kJ usable); a 3 kg
    parcel is over the 2.5 kg limit wherever it is."""
    from types import SimpleNamespace

    from marops_cli.energy import EnergyModel
    from marops_cli.sim.metrics import unservable

    day = SimpleNamespace(
        x_m=np.array([1000.0, 0.0, 100.0, 3000.0]),
        y_m=np.array([0.0, 5000.0, 0.0, 0.0]),
        weight_kg=np.array([1.0, 2.5, 3.0, 2.5]),  # the last: 3 km, 136.3 kJ, servable
    )
    assert unservable(day, np.array([[0.0, 0.0]]), EnergyModel()) == (1, 1)
