"""An evaluation's jobs dataset (docs/outputs.md "Evaluation"): one Parquet file per
finished job, written the moment the job finishes, so an interrupted or killed run
resumes where it stopped.

::

    OUT/jobs/_identity.json                       the run identity (runner.run_identity)
    OUT/jobs/hub=<h>/method=<m>/day=<YYYY-MM-DD>/s<setting>-r<repeat>.parquet

A job file holds the job's row of ``results.parquet`` (less ``combined_cost``, which
spans jobs, and less the partition keys, which its path gives), typed as there, with the
run identity and the job in its ``marops`` metadata. ``results.parquet`` is built from
these files in job order, whichever worker, machine or session wrote them.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any
from urllib.parse import quote

from ..data.arrow import parquet_rows, read_parquet, read_parquet_schema
from ..data.jsonfile import parse_json, read_small_text
from ..errors import InputError, RunError, option, switch
from ..io import output_set, run_meta
from ..io.ownership import JOBS_IDENTITY, remove_ours
from ..io.tables import with_meta, write_parquet
from .runner import Prepared, identity_changes, identity_doc
from .settings import Job
from .tables import KEY_COLUMNS, job_row, key_columns, row_table

IDENTITY_FILE = JOBS_IDENTITY  # "_": dataset readers (pyarrow.dataset) skip it
PARTITION = ("hub", "method", "day")


def job_key(job: Job) -> dict[str, Any]:
    """What a job file's metadata records of its job."""
    return {
        "index": job.index,
        "hub": job.hub,
        "setting": job.setting,
        "method": job.method,
        "repeat": job.repeat,
        "seed": job.seed,
        "day": job.day.isoformat(),
    }


def check_jobs_folder(root: Path) -> None:
    """``OUT/jobs`` is absent or a folder of its own: a link (another evaluation's jobs,
    cleared through it) or a file there is refused, naming it, before any work."""
    if root.is_symlink():
        raise InputError(
            f"is a link; the jobs folder below {option('out')} is marops's own: remove it "
            f"or choose another {option('out')}",
            file=root,
        )
    if os.path.lexists(root) and not root.is_dir():
        raise InputError(
            "is a file, not the folder where marops evaluate keeps its jobs; move it or choose "
            f"another {option('out')}",
            file=root,
        )


class JobStore:
    """The jobs dataset of one evaluation under ``root`` (``OUT/jobs``).

    :meth:`open` checks that ``root`` holds this run's jobs (same run identity) or none,
    and lists the jobs already finished; :meth:`add` writes one finished job atomically;
    :meth:`rows` reads every job's row back, in job order.
    """

    def __init__(
        self, root: Path, prep: Prepared, identity: str, built: Sequence[Path] = ()
    ) -> None:
        self.root = Path(root)
        self.built = [Path(p) for p in built]
        """The outputs an evaluation builds from its jobs (tables, figures, paired.csv,
        report.html): those marops wrote go with another run's jobs (:meth:`_start`)."""
        self.prep = prep
        self.identity = identity
        self._done: set[int] = set()
        self.resumed = 0  # jobs found finished by open()
        self._started = False  # the identity file is in place
        self._clear = False  # another run's jobs go before this run's first one

    def path(self, job: Job) -> Path:
        """``hub=<h>/method=<m>/day=<YYYY-MM-DD>/s<setting>-r<repeat>.parquet``."""
        return (
            self.root
            / f"hub={job.hub}"
            / f"method={quote(job.method, safe='')}"
            / f"day={job.day.isoformat()}"
            / f"s{job.setting}-r{job.repeat}.parquet"
        )

    def open(self, *, force: bool = False) -> None:
        """List the jobs of this run already under ``root``; jobs of another run are an
        error naming the folder (``force``: they are cleared when the first job of this
        run is written). Writes nothing: a run that fails before its first job leaves the
        folder as it was."""
        check_jobs_folder(self.root)
        held = self._held_identity()
        self._done = set()
        # A link (to a file or a folder) is never a job: writing there would write elsewhere.
        foreign = next((p for p in self._files() if p.is_symlink() or not _job_file(p)), None)
        if foreign is not None:
            raise InputError(
                "was not written by marops evaluate and lies among its jobs; move it or "
                f"choose another {option('out')}",
                file=foreign,
            )
        # A folder (or a pipe) where a job's file goes: the job could never be written.
        for job in self.prep.jobs:
            path = self.path(job)
            if os.path.lexists(path) and not path.is_file():
                what = "a folder" if path.is_dir() else "no regular file"
                raise InputError(
                    f"is {what} where marops evaluate writes a job's file; move it or "
                    f"choose another {option('out')}",
                    file=path,
                )
        if held is not None and held != self.identity:
            if not force:
                held_doc = self._held_doc()  # none in a dataset of an older marops
                changes = identity_changes(held_doc, identity_doc(self.prep)) if held_doc else []
                what = f" ({'; '.join(changes)})" if changes else ""
                raise InputError(
                    f"holds the jobs of an evaluation with other settings{what}; run with "
                    f"{switch('force')} to clear them, or choose another {option('out')}",
                    file=self.root,
                )
            self._clear = True
        elif held is not None:
            self._refuse_strays()
            self._started = True
            self._done = {job.index for job in self.prep.jobs if self._read(job) is not None}
        self.resumed = len(self._done)

    def _refuse_strays(self) -> None:
        """Refuse a job file of this run's dataset that lies where none of its jobs goes
        (moved under another ``day=`` or ``method=`` folder, or copied in): a reader of
        the dataset would take it for one more replay (docs/outputs.md, "Resume")."""
        places = {self.path(job) for job in self.prep.jobs}
        stray = next((p for p in self._files() if p not in places), None)
        if stray is None:
            return
        raise InputError(
            f"lies where no replay of this evaluation goes ({self._holds(stray)}); a "
            "replay's file is read only where marops wrote it: move it back or remove it",
            file=stray,
        )

    def _holds(self, path: Path) -> str:
        """Which replay a job file holds, by its metadata: ``it holds the replay of
        hub=0/method=stay/day=2022-08-11/s0-r0.parquet``."""
        try:
            meta = parse_json(read_parquet_schema(path).metadata[b"marops"])
            job = meta["job"]
            if meta.get("identity") != self.identity:
                return "it holds a replay of another evaluation"
            where = (
                f"hub={int(job['hub'])}/method={quote(str(job['method']), safe='')}/"
                f"day={job['day']}/s{int(job['setting'])}-r{int(job['repeat'])}.parquet"
            )
        except (OSError, ValueError, KeyError, TypeError):
            return "it names no replay of this evaluation"
        return f"it holds the replay of {where}"

    def _held_identity(self) -> str | None:
        """The run identity ``root`` holds; None for no folder or one with nothing in it."""
        if not self.root.exists():
            return None
        ident = self.root / IDENTITY_FILE
        if not ident.is_file():
            if not any(not p.name.startswith(".") for p in self.root.iterdir()):
                return None  # empty, or a killed run's temporaries (removed by the lock)
            raise InputError(
                f"exists and was not written by marops evaluate; choose another {option('out')}",
                file=self.root,
            )
        try:
            doc = parse_json(read_small_text(ident, "evaluation identity"))
            return str(doc["identity"])
        except (OSError, ValueError, KeyError, TypeError):
            return ""  # unreadable: another run's, whatever it was

    def _held_doc(self) -> dict[str, Any]:
        """What the identity ``root`` holds was made of (empty for a dataset written before
        marops recorded it, or an unreadable one)."""
        try:
            doc = parse_json(read_small_text(self.root / IDENTITY_FILE, "evaluation identity"))
            run = doc["run"]
        except (OSError, ValueError, KeyError, TypeError, InputError):
            return {}
        return run if isinstance(run, dict) else {}

    def finished(self) -> set[int]:
        """Indices of the jobs whose file is in place."""
        return set(self._done)

    def kept(self) -> int:
        """How many jobs have their file in place, counted on disk (after an interruption,
        which may fall between a file's rename and its count)."""
        return sum(self._read(job) is not None for job in self.prep.jobs)

    def add(self, job: Job, metrics: dict[str, Any]) -> None:
        """Write one finished job's file (a temporary, then renamed into place)."""
        row = {k: v for k, v in job_row(self.prep, job, metrics).items() if k not in PARTITION}
        meta = run_meta(
            command="evaluate", stamp=False, extra={"identity": self.identity, "job": job_key(job)}
        )
        table = with_meta(row_table(row), meta)
        if not self._started:
            self._start()
        self.path(job).unlink(missing_ok=True)  # not this job's, or open() would have kept it
        with output_set() as files:
            files.write_with(self.path(job), lambda p: write_parquet(table, p))
        self._done.add(job.index)

    def _files(self) -> list[Path]:
        """Every file under ``root`` but the identity file and hidden ones (a killed
        run's temporaries, removed by the lock), and every link (never followed)."""
        if not self.root.is_dir():
            return []
        return sorted(
            p
            for p in self.root.rglob("*")
            if (p.is_file() or p.is_symlink())
            and p.name != IDENTITY_FILE
            and not p.name.startswith(".")
        )

    def _start(self) -> None:
        """Clear another run's jobs (``--force``): the job files ``open`` found marops's,
        the folders they leave empty and the outputs marops built from them; then record
        this run's identity."""
        if self._clear:
            for p in self._files():
                p.unlink()
                d = p.parent
                while d != self.root and not any(d.iterdir()):
                    d.rmdir()
                    d = d.parent
            if self._held_identity():  # an evaluation's identity, read as such
                (self.root / IDENTITY_FILE).unlink()
            # Built from those jobs: they would read as this run's.
            remove_ours(self.built)
        doc = {
            "identity": self.identity,
            "jobs": len(self.prep.jobs),
            "run": identity_doc(self.prep),
            "meta": run_meta(command="evaluate", source=self.prep.source.source, stamp=False),
        }
        with output_set() as files:
            files.write_json(self.root / IDENTITY_FILE, doc)
        self._started = True

    def _read(self, job: Job) -> dict[str, Any] | None:
        """The job's row from its file; None when the file is missing or not this job's
        of this run."""
        path = self.path(job)
        if not path.is_file():
            return None
        try:
            # A job's file holds one row: its footer says so before any row is read (a
            # file of millions of repeated rows compresses to kilobytes).
            if parquet_rows(path) != 1:
                return None
            table = read_parquet(path)
            meta = parse_json((table.schema.metadata or {})[b"marops"])
        except (OSError, ValueError, KeyError):
            return None
        if meta.get("identity") != self.identity or meta.get("job") != job_key(job):
            return None
        row = table.to_pylist()[0]
        keys = {k: v for k, v in key_columns(self.prep, job).items() if k not in PARTITION}
        if any(row.get(k) != v for k, v in keys.items()):
            return None
        return row if _sound(row) else None

    def rows(self) -> list[dict[str, Any]]:
        """Every job's row, read back from its file, in job order (:func:`job_row`)."""
        rows = []
        for job in self.prep.jobs:
            found = self._read(job)
            if found is None:
                raise RunError(f"{self.path(job)}: a finished job's file is missing or damaged")
            row = key_columns(self.prep, job)
            row.update({k: v for k, v in found.items() if k not in KEY_COLUMNS})
            rows.append(row)
        return rows


_CORE = ("mean_energy_kj", "avg_delay_h", "delivered", "requests")
"""Metrics every job's row holds."""
_NOT_NEGATIVE = ("count", "kJ", "g", "s", "h", "0–1")
"""Units of metrics no replay makes negative."""
_NOT_NEGATIVE_KEYS = frozenset({"objective_j_mj"})
"""Metrics of another unit no replay makes negative: the day objective J (energy and
priced delay; G, its controllable part, may be below 0)."""
_AT_MOST_ONE = frozenset(
    {
        "delivered_share",
        "delay_unfairness",
        "actions_stay",
        "actions_move",
        "actions_free",
        "actions_idle",
    }
)
"""Shares of a whole (the battery used per flight is a share of a battery, kept apart)."""
_PER_KEY = ("depot_load_kg_", "drone_types_", "stock_left_")
"""Flattened metrics per depot or type: weights and counts."""


def _sound(row: dict[str, Any]) -> bool:
    """A job row as a job writes it: the core metrics there and every metric a finite
    number in its range (or empty): no count, energy, time or share below 0, no share of
    a whole above 1, no more delivered than requested. An edited file (a metric turned
    to text or NaN, a column dropped) is not, and its job runs again rather than feeding
    the tables."""
    from ..sim.metrics import METRICS

    if any(k not in row for k in _CORE):
        return False
    for k, v in row.items():
        if k in KEY_COLUMNS or v is None:
            continue
        if not isinstance(v, int | float) or not math.isfinite(v):
            return False
        spec = METRICS.get(k)
        positive = (
            k.startswith(_PER_KEY)
            or k in _NOT_NEGATIVE_KEYS
            or (spec is not None and spec.unit in _NOT_NEGATIVE)
        )
        if (positive and v < 0) or (k in _AT_MOST_ONE and v > 1):
            return False
    return bool(row["delivered"] <= row["requests"])


def _job_file(path: Path) -> bool:
    """A job file of some ``marops evaluate`` run: Parquet whose ``marops`` metadata names
    its job."""
    try:
        meta = parse_json(read_parquet_schema(path).metadata[b"marops"])
    except (OSError, ValueError, KeyError, TypeError):
        return False
    return isinstance(meta, dict) and "job" in meta
