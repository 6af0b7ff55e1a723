"""What an evaluation runs: settings of a sweep, held-out days, and the job list.

A *setting* is one value of each sweepable flag (α, drones, coverage, number of
depots). A *job* is one replayed day of one method under one setting and repeat;
its index fixes its place in the results, whichever worker runs it.
"""

from __future__ import annotations

import datetime as dt
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any, TypeVar

from ..config import PlannerConfig, ascii_number, override
from ..data.dates import split_by_date
from ..errors import InputError, option
from ..methods import method as method_spec

# Flag name -> (config field, label for tables and plots).
SWEEP_FLAGS: dict[str, tuple[str, str]] = {
    "alpha": ("plan__alpha", "trade-off weight α"),
    "drones": ("sim__drones", "number of drones"),
    "coverage": ("plan__coverage", "flying coverage density"),
    "depots_n": ("segment__n_depots", "number of service areas"),
}

T = TypeVar("T", int, float)

MAX_REPEATS = 1000
"""The most runs per day (``--repeats``, docs/config.md): each repeat replays every day
of every method and setting again, so 1000 is already more replays than any study
needs, and the job list stays small."""


def check_repeats(repeats: int) -> None:
    """``--repeats`` within 1 ≤ repeats ≤ :data:`MAX_REPEATS`, else one line naming it."""
    if not 1 <= repeats <= MAX_REPEATS:
        raise InputError(
            f"invalid option {option('repeats')}: got {repeats} "
            f"(expected 1 ≤ repeats ≤ {MAX_REPEATS}, docs/config.md)"
        )


MAX_REPLAYS = 100_000
"""The most replays one evaluation runs (settings × methods × repeats × days, a city's
hubs counting their days each; docs/config.md): days of work on any machine, far more
than a study needs. A larger sweep is refused before its settings or jobs are listed."""


def check_replays(parts: Sequence[tuple[int, str, str]]) -> None:
    """Refuse more than :data:`MAX_REPLAYS` replays, counted as the product of ``parts``
    (a count with what one and several of it are called: ``(12, "method", "methods")``),
    before any list of them is made; one line naming the counts and the bound."""
    total = math.prod(n for n, _, _ in parts)
    if total > MAX_REPLAYS:
        said = " × ".join(f"{n:,} {one if n == 1 else many}" for n, one, many in parts)
        raise InputError(
            f"the evaluation would run {total:,} replays ({said}), more than the "
            f"{MAX_REPLAYS:,} one evaluation runs (docs/config.md); give fewer values or "
            "split the sweep over several runs"
        )


@dataclass(frozen=True)
class Setting:
    """One point of a sweep."""

    alpha: float
    drones: int
    coverage: float
    depots_n: int

    def columns(self) -> dict[str, Any]:
        """The setting as result columns."""
        return asdict(self)

    def config(self, base: PlannerConfig, method: str, seed: int) -> PlannerConfig:
        """``base`` with this setting, the method's segmentation and ``seed`` applied."""
        fields = {cfg_field: getattr(self, flag) for flag, (cfg_field, _) in SWEEP_FLAGS.items()}
        # A bad value is named by the option that swept it (--alpha), not by its field.
        names = {
            cfg_field: option("n_depots" if flag == "depots_n" else flag)
            for flag, (cfg_field, _) in SWEEP_FLAGS.items()
        }
        return override(
            base,
            names,
            segment__method=method_spec(method).segmentation,
            sim__seed=seed,
            **fields,
        )


@dataclass(frozen=True)
class Job:
    """One day of one method under one setting and repeat (at one hub).

    ``hub`` is a partition key of the jobs dataset (docs/outputs.md "Evaluation"): 0 for
    a single study area, the hub's id with ``--hubs``.
    """

    index: int
    setting: int  # index into the settings list
    method: str
    repeat: int
    seed: int
    day: dt.date
    hub: int = 0


def parse_values(text: str | None, kind: Callable[[str], T], name: str) -> list[T] | None:
    """``"0.2,0.5,0.8"`` -> ``[0.2, 0.5, 0.8]`` (None stays None: use the config's value);
    a bad value is an error naming ``name`` (``option("alpha")``, marops_cli/errors.py),
    and so is one not in ASCII digits (:func:`~marops_cli.config.ascii_number`)."""
    if text is None:
        return None
    values: list[T] = []
    for item in str(text).split(","):
        try:
            values.append(ascii_number(item.strip(), kind))
        except ValueError:
            what = "whole numbers" if kind is int else "numbers"
            raise InputError(f"{name} expects {what} separated by commas, got {text!r}") from None
    return list(dict.fromkeys(values))


def expand_settings(
    cfg: PlannerConfig,
    *,
    alpha: Sequence[float] | None = None,
    drones: Sequence[int] | None = None,
    coverage: Sequence[float] | None = None,
    depots_n: Sequence[int] | None = None,
) -> list[Setting]:
    """Every combination of the given values (a flag left out keeps the config's value).

    The order is fixed (α slowest, depots fastest) so results always line up the same.
    More combinations than :data:`MAX_REPLAYS` are refused before any is made.
    """
    axes = (
        list(alpha) if alpha else [cfg.plan.alpha],
        list(drones) if drones else [cfg.sim.drones],
        list(coverage) if coverage else [cfg.plan.coverage],
        list(depots_n) if depots_n else [cfg.segment.n_depots],
    )
    names = [option("n_depots" if flag == "depots_n" else flag) for flag in SWEEP_FLAGS]
    counts = [len(axis) for axis in axes]
    swept = zip(counts, names, strict=True)
    check_replays([(k, f"{n} value", f"{n} values") for k, n in swept if k > 1])
    return [Setting(float(a), int(u), float(c), int(n)) for a, u, c, n in itertools.product(*axes)]


def swept_flags(settings: Sequence[Setting]) -> list[str]:
    """The flags that take more than one value, in :data:`SWEEP_FLAGS` order."""
    return [f for f in SWEEP_FLAGS if len({getattr(s, f) for s in settings}) > 1]


def check_settings(cfg: PlannerConfig, settings: Sequence[Setting], methods: Sequence[str]) -> None:
    """Validate every setting × method config up front, so no worker fails half-way."""
    for s in settings:
        for m in methods:
            try:
                s.config(cfg, m, cfg.sim.seed)
            except InputError as exc:
                # The template, whose options each caller spells (--alpha, alpha=).
                plain = exc.file is None and exc.row is None and exc.column is None
                said = exc.template if plain else str(exc)
                raise InputError(f"method {m} with {_describe(s)}: {said}") from None


def _describe(s: Setting) -> str:
    return f"alpha={s.alpha:g}, drones={s.drones}, coverage={s.coverage:g}, depots={s.depots_n}"


def split_days(days: Sequence[dt.date], split: str) -> list[dt.date]:
    """The last 20 % of the file's dates (``test``) or the first 80 % (``train``): the
    split of ``marops train`` (:func:`~marops_cli.data.dates.split_by_date`)."""
    if split not in ("test", "train"):
        raise InputError(f"{option('split')} expects test or train, got {split!r}")
    if len(days) < 2:
        named = f": name its day with {option('dates')} {days[0]:%m%d}" if days else ""
        raise InputError(
            f"{option('split')} {split} (by default test: the last 20 % of the file's days) needs "
            f"at least 2 days in the file, it has {len(days)}{named}"
        )
    train, test = split_by_date(days)
    return test if split == "test" else train


def replay_counts(
    n_settings: int, methods: Sequence[str], repeats: int
) -> list[tuple[int, str, str]]:
    """The counts an evaluation's replays multiply, its days aside (:func:`check_replays`)."""
    return [
        (n_settings, "setting", "settings"),
        (len(methods), "method", "methods"),
        (repeats, "repeat", "repeats"),
    ]


def plan_jobs(
    n_settings: int,
    methods: Sequence[str],
    days: Sequence[dt.date],
    repeats: int,
    seed: int,
    *,
    hub_days: Sequence[tuple[int, Sequence[dt.date]]] | None = None,
) -> list[Job]:
    """Jobs ordered setting, method, repeat, hub, day; repeat ``r`` runs with seed
    ``seed + r``. ``days`` are the days of the one study area (hub 0); ``hub_days``, for
    a city, gives each hub with its own days instead."""
    check_repeats(repeats)
    areas = list(hub_days) if hub_days is not None else [(0, days)]
    check_replays(
        [
            *replay_counts(n_settings, methods, repeats),
            (sum(len(d) for _, d in areas), "day", "days"),
        ]
    )
    jobs: list[Job] = []
    for s, m, r in itertools.product(range(n_settings), methods, range(repeats)):
        for hub, area_days in areas:
            for d in area_days:
                jobs.append(Job(len(jobs), s, m, r, seed + r, d, hub))
    return jobs
