"""The planner config of the use cases' options: which option sets which config field,
one mapping for the commands' flags and the Python API's keyword arguments."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..config import PlannerConfig, load_config, override
from ..errors import InputError, option
from .inputs import parse_center

# Option name -> config field (``stage__field`` of marops_cli/config.py).
FIELDS = {
    "year": "data__year",
    "strict": "data__strict",
    "tz": "data__tz",
    "size_km": "data__size_km",
    "center": "data__center",
    "area": "data__area",
    "n_depots": "segment__n_depots",
    "segmentation": "segment__method",
    "actions": "segment__n_actions",
    "segment_seed": "segment__seed",
    "alpha": "plan__alpha",
    "ordering": "plan__ordering",
    "strict_cover": "plan__strict_cover",
    "drones": "sim__drones",
    "city_drones": "sim__city_drones",
    "seed": "sim__seed",
    "policy": "sim__policy",
    "trust_actor": "sim__trust_actor",
}


def planner_config(config: str | Path | None, **options: Any) -> PlannerConfig:
    """The TOML config (or the defaults) with the options applied on top: an option left
    unset (None) or a switch left off (False) keeps the config's value; ``center`` may be
    ``"LNG,LAT"`` text. An invalid value is an error naming its option (``--alpha`` on
    the command line, ``alpha`` in the API: marops_cli/errors.py). An unknown option name
    is a ``TypeError``."""
    unknown = set(options) - set(FIELDS)
    if unknown:
        raise TypeError(f"not planner options: {sorted(unknown)}")
    if isinstance(options.get("center"), str):  # a bad centre is named before the file is read
        options["center"] = parse_center(options["center"])
    overrides = {
        FIELDS[name]: (value or None) if isinstance(value, bool) else value
        for name, value in options.items()
    }
    names = {FIELDS[name]: option(name) for name in options}  # an error names the option
    cfg = override(load_config(Path(config) if config is not None else None), names, **overrides)
    seg = cfg.segment
    if options.get("actions") is not None and seg.n_actions > seg.n_depots:
        # Each depot's candidates are itself and its nearest others: never more than
        # there are depots, and a depots file with fewer than asked misleads a replay.
        actions, n_depots = option("actions"), option("n_depots")
        raise InputError(
            f"{actions} {seg.n_actions} asks for more action candidates than {seg.n_depots} "
            f"depots offer (itself and its nearest others); give {actions} {seg.n_depots} "
            f"or fewer, or {n_depots} {seg.n_actions} or more"
        )
    return cfg
