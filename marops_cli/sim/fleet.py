"""The fleet: where each drone starts and what type of drone it is (docs/method.md §5.1).

A *drone type* is a name and a full set of drone parameters (:class:`EnergyConfig`:
battery capacity and reserve, payload limit, speed, body mass and the energy
parameters); a type in a fleet file lists only the parameters that differ from the
config's ``[energy]`` table. Energy models are built once per type.

A fleet file is TOML or JSON (docs/outputs.md, "Fleet file"):

* a list of depot ids, ``[3, 3, 5]`` (one drone of the default type each), or
* a table with ``types`` (name -> parameters) and either ``drones`` (a list of
  ``{depot, type}``; ``type`` may be left out when the fleet has one type) or
  ``counts`` (type -> number of drones, placed over the busiest depots in file
  order, as the default fleet is).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from ..config import MAX_DRONES, EnergyConfig, check_file_types, value_range
from ..data.jsonfile import json_number, read_document
from ..energy import EnergyModel
from ..errors import InputError
from ..segment.depots import Depots

__all__ = ["DEFAULT_TYPE", "DroneType", "Fleet", "default_fleet", "load_fleet"]

DEFAULT_TYPE = "default"
"""The name of the one type of a fleet made without a fleet file (the config's [energy])."""


def default_fleet(depots: Depots, n_drones: int) -> np.ndarray:
    """Drones spread over the busiest depots: drone u at the u-th busiest (wrapping)."""
    order = np.lexsort((np.arange(len(depots)), -depots.n_history))
    return order[np.arange(n_drones) % len(depots)].astype(np.int64)


@dataclass(frozen=True)
class DroneType:
    """A named kind of drone: its parameters and its energy model (built once per
    process, :meth:`EnergyModel.of`)."""

    name: str
    energy: EnergyConfig

    @property
    def model(self) -> EnergyModel:
        return EnergyModel.of(self.energy)


@dataclass(frozen=True)
class Fleet:
    """Each drone's start depot and type (``kind[u]`` indexes ``types``)."""

    depot: np.ndarray
    kind: np.ndarray
    types: tuple[DroneType, ...]

    @classmethod
    def uniform(cls, depot: np.ndarray, energy: EnergyConfig) -> Fleet:
        """Every drone of one type, the default one (the config's ``[energy]``)."""
        depot = np.asarray(depot, dtype=np.int64)
        return cls(depot, np.zeros(depot.size, np.int64), (DroneType(DEFAULT_TYPE, energy),))

    def __len__(self) -> int:
        return int(self.depot.size)

    @property
    def mixed(self) -> bool:
        return len(self.types) > 1

    def models(self) -> tuple[EnergyModel, ...]:
        """Each drone's energy model (one object per type, shared)."""
        return tuple(self.types[int(k)].model for k in self.kind)

    def type_names(self) -> list[str]:
        return [self.types[int(k)].name for k in self.kind]

    def describe(self, base: EnergyConfig) -> dict[str, Any]:
        """What the fleet is, for provenance: each drone's depot and type, and each
        type's parameters that differ from ``base`` (a file that gives the default
        fleet is described as no file is)."""
        ref = base.model_dump()
        return {
            "depot": [int(d) for d in self.depot],
            "type": self.type_names(),
            "types": {
                t.name: {k: v for k, v in t.energy.model_dump().items() if ref[k] != v}
                for t in self.types
            },
        }

    def counts(self) -> dict[str, int]:
        """Drones per type, in the fleet's type order."""
        n = np.bincount(self.kind, minlength=len(self.types))
        return {t.name: int(c) for t, c in zip(self.types, n, strict=True)}


def _read(path: Path) -> Any:
    return read_document(path, "fleet file")  # TOML for a .toml name, else JSON


def _types(doc: dict[str, Any], base: EnergyConfig, path: Path) -> tuple[DroneType, ...]:
    raw = doc.get("types")
    if raw is None:
        return (DroneType(DEFAULT_TYPE, base),)
    if not isinstance(raw, dict) or not raw:
        raise InputError("'types' must map type names to parameters", file=path, column="types")
    out = []
    for name, params in raw.items():
        key = f"types.{name}"
        if not isinstance(params, dict):
            raise InputError("a drone type must be a table of parameters", file=path, column=key)
        unknown = sorted(set(params) - set(EnergyConfig.model_fields))
        if unknown:
            raise InputError(
                f"unknown drone parameter {unknown[0]!r} (expected some of: "
                f"{', '.join(EnergyConfig.model_fields)})",
                file=path,
                column=f"{key}.{unknown[0]}",
            )
        check_file_types(EnergyConfig, params, path, f"{key}.")
        try:
            energy = EnergyConfig.model_validate({**base.model_dump(), **params})
        except ValidationError as exc:
            err = exc.errors()[0]
            field = ".".join(str(p) for p in err["loc"])
            msg = str(err["msg"]).removeprefix("Value error, ")
            rng = value_range("energy", field) if field in EnergyConfig.model_fields else None
            if rng is not None:
                msg += f" (expected {rng.replace('x', field)}, docs/config.md)"
            raise InputError(
                f"invalid drone parameter: {msg}", file=path, column=f"{key}.{field}"
            ) from exc
        out.append(DroneType(str(name), energy))
    return tuple(out)


def _int(value: Any, path: Path, column: str) -> int:
    return int(json_number(value, path, column, whole=True))


def load_fleet(
    path: str | Path | None, depots: Depots, n_drones: int, energy: EnergyConfig
) -> Fleet:
    """The fleet of a fleet file (module docstring), else ``n_drones`` drones of the
    default type spread over the busiest depots."""
    if path is None:
        return Fleet.uniform(default_fleet(depots, n_drones), energy)
    p = Path(path)
    doc = _read(p)
    if isinstance(doc, list):
        doc = {"drones": doc}
    if not isinstance(doc, dict):
        raise InputError("expected a list of depot ids or a table of types and drones", file=p)
    unknown = sorted(set(doc) - {"types", "drones", "counts"})
    if unknown:
        raise InputError(
            f"unknown key {unknown[0]!r} (expected types, drones or counts)",
            file=p,
            column=unknown[0],
        )
    types = _types(doc, energy, p)
    if ("drones" in doc) == ("counts" in doc):
        raise InputError("give either 'drones' (depot and type each) or 'counts'", file=p)
    if "counts" in doc:
        kind = _from_counts(doc["counts"], types, p)
        depot = default_fleet(depots, len(kind))
    else:
        depot, kind = _from_drones(doc["drones"], types, depots, p)
    if kind.size == 0:
        raise InputError("the fleet file lists no drones", file=p)
    return Fleet(depot, kind, types)


def _check_size(n: int, path: Path, column: str) -> None:
    if n > MAX_DRONES:
        raise InputError(
            f"a fleet of {n} drones is more than the {MAX_DRONES} one study area plans for "
            "(docs/config.md)",
            file=path,
            column=column,
        )


def _type_index(name: Any, types: tuple[DroneType, ...], path: Path, column: str) -> int:
    names = [t.name for t in types]
    if name not in names:
        raise InputError(
            f"type {name!r} is not among the types ({', '.join(names)})", file=path, column=column
        )
    return names.index(name)


def _from_counts(counts: Any, types: tuple[DroneType, ...], path: Path) -> np.ndarray:
    """Each drone's type index, from ``counts`` (type -> number, in file order)."""
    if not isinstance(counts, dict):
        raise InputError("'counts' must map type names to numbers", file=path, column="counts")
    kind: list[int] = []
    for name, c in counts.items():
        col = f"counts.{name}"
        k = _type_index(name, types, path, col)
        n = _int(c, path, col)
        if n < 0:
            raise InputError("a count cannot be negative", file=path, column=col)
        _check_size(len(kind) + n, path, col)  # before the list is made
        kind += [k] * n
    return np.array(kind, dtype=np.int64)


def _from_drones(
    items: Any, types: tuple[DroneType, ...], depots: Depots, path: Path
) -> tuple[np.ndarray, np.ndarray]:
    """Each drone's depot and type index, from ``drones`` (depot ids or {depot, type})."""
    if not isinstance(items, list):
        raise InputError("'drones' must be a list", file=path, column="drones")
    _check_size(len(items), path, "drones")
    depot, kind = [], []
    for u, d in enumerate(items):
        col = f"drones[{u}]"
        if not isinstance(d, dict):
            d = {"depot": d}
        unknown = sorted(set(d) - {"depot", "type"})
        if unknown:
            raise InputError(
                f"unknown drone key {unknown[0]!r} (expected depot and type)",
                file=path,
                column=f"{col}.{unknown[0]}",
            )
        if "depot" not in d:
            raise InputError("a drone needs a depot", file=path, column=f"{col}.depot")
        at = _int(d["depot"], path, f"{col}.depot")
        if not 0 <= at < len(depots):  # checked here: an id past 2**63 fits no array
            raise InputError(
                f"drone {u} is at depot {at}, but the depots have ids 0..{len(depots) - 1}",
                file=path,
                column=f"{col}.depot",
            )
        depot.append(at)
        name = d.get("type")
        if name is None and len(types) > 1:
            raise InputError(
                "the fleet has several types: name this drone's type",
                file=path,
                column=f"{col}.type",
            )
        kind.append(0 if name is None else _type_index(name, types, path, f"{col}.type"))
    return np.array(depot, dtype=np.int64), np.array(kind, dtype=np.int64)


def as_fleet(fleet: Fleet | Sequence[int] | np.ndarray, energy: EnergyConfig) -> Fleet:
    """A :class:`Fleet` from a fleet or from depot ids (every drone of the default type)."""
    if isinstance(fleet, Fleet):
        return fleet
    return Fleet.uniform(np.asarray(fleet, dtype=np.int64), energy)
