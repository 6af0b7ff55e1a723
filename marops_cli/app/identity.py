"""What makes a replayed day what it is, and whether an earlier day folder was made the
same way (``replay-day`` resumes a run by keeping such days, docs/outputs.md)."""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..config import clipped
from ..data.dates import format_days
from ..data.jsonfile import parse_json, read_small_text
from ..errors import InputError, option, switch
from ..io import run_meta
from .inputs import depots_record

if TYPE_CHECKING:
    from ..segment.depots import Depots
    from ..sim.scenario import Scenario


def identity(
    scn: Scenario,
    method: str,
    policy_id: Any,
    depots: Path | Depots | None,
    fmt: str,
    fleet: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Version, config, input, depots, fleet, policy, method, seed and format of a
    replayed day: recorded in every day's metrics.json under ``settings``."""
    cfg = scn.cfg
    meta = run_meta(
        command="replay-day",
        config=cfg,
        source=scn.table.source,
        policy=policy_id,
        method=method,
        seed=cfg.sim.seed,
        stamp=False,
    )
    meta["frame"] = {
        "center_lng": scn.frame.center_lng,
        "center_lat": scn.frame.center_lat,
        "size_km": scn.frame.size_km,
    }
    if depots is not None:  # a depots file's name and hash, or those of depots in memory
        meta["depots_file"] = depots_record(depots)
    if fleet is not None:  # the resolved fleet: where each drone starts, its type
        meta["fleet"] = fleet
    # The file's days not replayed: they give the arrival profile (and the depots and
    # study square, when segmented here), so another range of days plans other routes.
    meta["history_days"] = [d.isoformat() for d in scn.history_days]
    meta["format"] = fmt
    meta.pop("command", None)
    return meta


def route_meta(ident: dict[str, Any], day: dt.date) -> dict[str, Any]:
    """The ``marops`` metadata of a replayed day's route files: the run's identity (less
    the file format and the history days, which metrics.json records) and the day."""
    meta = {k: v for k, v in ident.items() if k not in ("format", "history_days")}
    meta.update(command="replay-day", day=day.isoformat())
    return meta


def written_with(path: Path, meta: dict[str, Any]) -> bool:
    """Whether the route file ``path`` (Parquet, JSON or GeoJSON) carries ``meta`` as its
    ``marops`` metadata: the output of the run and day ``meta`` describes, not another
    day's copied in or a window's of ``plan-window``. False for a file that does not
    read as one."""
    import json

    try:
        if path.suffix == ".parquet":
            from ..data.arrow import read_parquet_schema

            held = parse_json((read_parquet_schema(path).metadata or {})[b"marops"])
        else:  # its metadata only, not a day's stops
            from ..io.routejson import route_json_meta

            held = route_json_meta(path, "marops" if path.suffix == ".geojson" else "meta")
    except (OSError, ValueError, KeyError, TypeError, InputError):
        return False
    # As the file holds it: through JSON (a tuple reads back as a list).
    return bool(held == json.loads(json.dumps(meta)))


def _flatten(doc: Any, prefix: str = "") -> dict[str, Any]:
    if not isinstance(doc, dict):
        return {prefix: doc}
    out: dict[str, Any] = {}
    for k, v in doc.items():
        out.update(_flatten(v, f"{prefix}.{k}" if prefix else str(k)))
    return out


def matching_days(
    done: Path, ident: dict[str, Any], day: dt.date, required: Sequence[str] = ()
) -> list[dict[str, Any]]:
    """The day records of ``done`` if it was made with ``ident``; else a clear error. A
    record kept must be the day's (``day``, the method of ``ident``) and give each metric
    as a finite number (``required``: the ones a run's totals read), as marops wrote it:
    an edited one is refused, naming its key."""
    try:
        doc = parse_json(read_small_text(done, "earlier output"))
        prior = doc["meta"].get("settings")
        days = doc["days"]
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
        raise InputError(
            f"unreadable earlier output ({exc}); pass {switch('force')} to replay or choose "
            f"another {option('out')}",
            file=done,
        ) from exc
    if not isinstance(prior, dict):
        raise InputError(
            f"earlier output without recorded settings; pass {switch('force')} to replay or "
            f"choose another {option('out')}",
            file=done,
        )
    old, new = _flatten(prior), _flatten(ident)
    diff = [k for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)]
    if diff:
        shown = "; ".join(
            f"{k}: {_shown(k, old.get(k))} here, {_shown(k, new.get(k))} now" for k in diff[:3]
        )
        more = f" (+{len(diff) - 3} more)" if len(diff) > 3 else ""
        raise InputError(
            f"holds a replay made with other settings ({shown}{more}); pass "
            f"{switch('force')} to replay it or choose another {option('out')}",
            file=done,
        )
    _check_records(done, days, day, ident.get("method"), required)
    return list(days)


def _shown(key: str, value: Any) -> str:
    """A setting's value in a message: the history days as runs of consecutive days
    (``'2022-08-01..2022-08-08, 2022-08-12'``), anything else as Python writes it."""
    if key != "history_days" or not isinstance(value, list) or not value:
        return repr(value)
    try:
        days = [dt.date.fromisoformat(d) for d in value]
    except (TypeError, ValueError):
        return repr(value)
    return repr(format_days(days, most=len(days)))


def _check_records(
    done: Path, days: Any, day: dt.date, method: Any, required: Sequence[str]
) -> None:
    """Refuse day records that are not the one record of ``day`` and ``method`` with
    finite numbers for its metrics (``required`` present)."""
    from ..sim.metrics import DAY_METRICS, OPS_METRICS

    fix = f"pass {switch('force')} to replay it or choose another {option('out')}"
    if not isinstance(days, list) or len(days) != 1 or not isinstance(days[0], dict):
        raise InputError(
            f"expected the one record of {day.isoformat()} under days; {fix}",
            file=done,
            column="days",
        )
    rec = days[0]
    for key, want in (("day", day.isoformat()), ("method", method)):
        if rec.get(key) != want:
            raise InputError(
                f"expected {want!r}, got {clipped(repr(rec.get(key)))}; {fix}",
                file=done,
                column=f"days[0].{key}",
            )
    for name in (m.name for m in (*DAY_METRICS, *OPS_METRICS)):
        if name not in rec and name not in required:
            continue
        value = rec.get(name)
        if value is None and name not in required:
            continue  # a metric without a value that day (charged_min of unlimited swaps)
        if isinstance(value, bool) or not isinstance(value, int | float):
            finite = False
        else:  # a whole number beyond a float's range is no metric either
            finite = math.isfinite(value) if isinstance(value, float) else abs(value) < 2**63
        if not finite:
            raise InputError(
                f"expected a number, got {clipped(repr(value))}; {fix}",
                file=done,
                column=f"days[0].{name}",
            )
