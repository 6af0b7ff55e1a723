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
from typing import Annotated, Any, ClassVar

import numpy as np
from pydantic import Field

from ..config import MAX_DRONES, EnergyConfig, check_file_types
from ..data.filemodel import FileModel, Whole, validated
from ..data.jsonfile import read_document
from ..energy import MAX_TABLE_ENTRIES, EnergyModel, table_steps
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


class _Drone(FileModel):
    """A drone of a fleet file's ``drones``: its start depot and its type's name."""

    noun: ClassVar[str] = "drone"
    depot: Whole
    type: str | None = None


class _FleetFile(FileModel):
    """A fleet file (module docstring): ``types`` and either ``drones`` or ``counts``; a
    type's parameters are :class:`EnergyConfig`'s (:func:`_types`)."""

    noun: ClassVar[str] = "fleet file"
    shape: ClassVar[str] = "a list of depot ids or a table of types and drones"
    types: dict[str, dict[str, Any]] | None = Field(
        None, min_length=1, description="type names mapped to tables of drone parameters"
    )
    drones: list[_Drone] | None = None
    counts: dict[str, Annotated[Whole, Field(ge=0)]] | None = Field(
        None, description="type names mapped to numbers of drones"
    )


class _DroneType(EnergyConfig):
    """A drone type's parameters: :class:`EnergyConfig` as a file gives it (unknown keys
    named as a drone type's)."""

    noun: ClassVar[str] = "drone type"


def _types(doc: _FleetFile, base: EnergyConfig, path: Path) -> tuple[DroneType, ...]:
    if doc.types is None:
        return (DroneType(DEFAULT_TYPE, base),)
    out = []
    for name, params in doc.types.items():
        key = f"types.{name}."
        check_file_types(EnergyConfig, params, path, key)  # what validation would convert
        given = validated(_DroneType, {**base.model_dump(), **params}, path, key)
        out.append(DroneType(str(name), EnergyConfig.model_validate(given.model_dump())))
    return tuple(out)


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
    if isinstance(doc, dict) and isinstance(doc.get("drones"), list):
        _check_size(len(doc["drones"]), p, "drones")  # before any drone's work
        # A drone is its depot id alone, or a table of its depot and type.
        doc = {**doc, "drones": [d if isinstance(d, dict) else {"depot": d} for d in doc["drones"]]}
    file = validated(_FleetFile, doc, p)
    types = _types(file, energy, p)
    if (file.drones is None) == (file.counts is None):
        raise InputError("give either 'drones' (depot and type each) or 'counts'", file=p)
    if file.counts is not None:
        kind = _from_counts(file.counts, types, p)
        depot = default_fleet(depots, len(kind))
    else:
        depot, kind = _from_drones(file.drones or [], types, depots, p)
    if kind.size == 0:
        raise InputError("the fleet file lists no drones", file=p)
    _check_tables([types[int(k)] for k in np.unique(kind)], p)
    return Fleet(depot, kind, types)


def _check_tables(used: list[DroneType], path: Path) -> None:
    """Refuse, before any table is built, drone types whose payload tables (one per type
    the drones use, :class:`~marops_cli.energy.EnergyModel`) would together have more
    than :data:`~marops_cli.energy.MAX_TABLE_ENTRIES` entries."""
    distinct = {t.energy.model_dump_json(): t.energy for t in used}  # as EnergyModel.of shares
    entries = sum(table_steps(cfg) + 1 for cfg in distinct.values())
    if entries > MAX_TABLE_ENTRIES:
        raise InputError(
            f"its {len(distinct)} drone types need payload tables of {entries:,} entries "
            f"together (max_payload_kg / table_step_kg + 1 each), more than the "
            f"{MAX_TABLE_ENTRIES:,} a run builds: use fewer types, a larger table_step_kg "
            "or a lower max_payload_kg",
            file=path,
            column="types",
        )


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


def _from_counts(counts: dict[str, int], types: tuple[DroneType, ...], path: Path) -> np.ndarray:
    """Each drone's type index, from ``counts`` (type -> number, in file order)."""
    kind: list[int] = []
    for name, n in counts.items():
        col = f"counts.{name}"
        k = _type_index(name, types, path, col)
        _check_size(len(kind) + n, path, col)  # before the list is made
        kind += [k] * n
    return np.array(kind, dtype=np.int64)


def _from_drones(
    items: list[_Drone], types: tuple[DroneType, ...], depots: Depots, path: Path
) -> tuple[np.ndarray, np.ndarray]:
    """Each drone's depot and type index, from ``drones``."""
    depot, kind = [], []
    for u, d in enumerate(items):
        col = f"drones[{u}]"
        if not 0 <= d.depot < len(depots):  # checked here: an id past 2**63 fits no array
            raise InputError(
                f"drone {u} is at depot {d.depot}, but the depots have ids 0..{len(depots) - 1}",
                file=path,
                column=f"{col}.depot",
            )
        depot.append(d.depot)
        if d.type is None and len(types) > 1:
            raise InputError(
                "the fleet has several types: name this drone's type",
                file=path,
                column=f"{col}.type",
            )
        kind.append(0 if d.type is None else _type_index(d.type, types, path, f"{col}.type"))
    return np.array(depot, dtype=np.int64), np.array(kind, dtype=np.int64)


def as_fleet(fleet: Fleet | Sequence[int] | np.ndarray, energy: EnergyConfig) -> Fleet:
    """A :class:`Fleet` from a fleet or from depot ids (every drone of the default type)."""
    if isinstance(fleet, Fleet):
        return fleet
    return Fleet.uniform(np.asarray(fleet, dtype=np.int64), energy)
