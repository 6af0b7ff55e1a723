"""The ``marops`` metadata block carried by every output file (docs/outputs.md)."""

from __future__ import annotations

import datetime as dt
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .. import __version__
from ..data.digest import sha256_file

if TYPE_CHECKING:
    from ..config import PlannerConfig
    from ..data.table import SourceInfo

# One file hash for every file marops identifies (inputs, depots, actors).
file_sha256 = sha256_file


def run_meta(
    *,
    command: str,
    config: PlannerConfig | None = None,
    source: SourceInfo | None = None,
    policy: str | Path | None = None,
    method: str | None = None,
    seed: int | None = None,
    extra: dict[str, Any] | None = None,
    stamp: bool = True,
) -> dict[str, Any]:
    """Version, resolved config, input identity, policy identity, method and seed.

    ``stamp`` adds the run's UTC time. Route files are written without it, so the
    same input, config and seed give byte-identical files.
    """
    meta: dict[str, Any] = {"package": "marops", "version": __version__, "command": command}
    if stamp:
        meta["created"] = dt.datetime.now(dt.UTC).replace(microsecond=0).isoformat()
    if config is not None:
        meta["config"] = config.model_dump(mode="json")
    if source is not None:
        meta["input"] = source.to_dict()
    if policy is not None:
        meta["policy"] = policy_identity(policy)
    if method is not None:
        meta["method"] = method
    if seed is not None:
        meta["seed"] = seed
    if extra:
        meta.update(extra)
    return meta


def policy_identity(policy: str | Path) -> dict[str, Any]:
    """A policy as outputs record it: its name; for an actor file its SHA-256 and, when
    the actor loads from the weights file beside it, that file's (``weights_sha256``):
    the numbers that actually ran (docs/method.md §6)."""
    p = Path(str(policy))
    if not p.is_file():
        return {"name": str(policy)}
    from ..policies.weights import weights_path  # deferred: policies imports the planner

    out = {"name": p.name, "sha256": file_sha256(p)}
    if weights_path(p) != p and weights_path(p).is_file():  # not a weights-only actor
        out["weights_sha256"] = file_sha256(weights_path(p))
    return out
