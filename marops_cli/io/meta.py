"""The ``marops`` metadata block carried by every output file (docs/outputs.md)."""

from __future__ import annotations

import datetime as dt
import hashlib
from pathlib import Path
from typing import Any

from .. import __version__
from ..config import PlannerConfig
from ..data.table import SourceInfo


def file_sha256(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


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
        p = Path(str(policy))
        meta["policy"] = (
            {"name": p.name, "sha256": file_sha256(p)} if p.is_file() else {"name": str(policy)}
        )
    if method is not None:
        meta["method"] = method
    if seed is not None:
        meta["seed"] = seed
    if extra:
        meta.update(extra)
    return meta
