"""One validated pydantic model per stage, gathered in :class:`PlannerConfig`.

A TOML file with one table per stage (``[data]``, ``[segment]``, ``[energy]``,
``[plan]``, ``[sim]``, ``[ops]``) loads into :class:`PlannerConfig`; command-line flags
override single fields afterwards with :func:`override`.
"""

from __future__ import annotations

import json
import re
import types
import typing
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Literal, TypeVar

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic.fields import FieldInfo

from .data.jsonfile import parse_toml, read_document, read_small_text
from .data.settings import MAX_SEED
from .errors import InputError, SettingError
from .methods import unknown_policy

MAX_DRONES = 1000
"""The most drones one study area plans for (``--drones``, a fleet file, a hub's
``drones``): a window of 1000 drones plans in seconds; a larger fleet is refused up
front rather than planned for hours (docs/config.md)."""
MAX_DAY_ROUTES = 24 * 60 * MAX_DRONES
"""The most routes of one study area's day: one per drone and window, of at most 1440
windows (``data.windows``)."""
MAX_DAY_STOPS = 1_000_000 + 2 * MAX_DAY_ROUTES
"""The most stops of one study area's day: a customer's for each order of the busiest
day (``synth --orders-per-day`` at most) and two depots' for each route. A stops or
routes file of more rows was written by no run: millions of repeated rows compress to
kilobytes, and a reader that reads them first takes gigabytes."""
MAX_DEPOTS = 4096
"""The most depots one study area has (``segment.n_depots``, a depots file, the depots
cache): every window sets up a flight range per depot and action candidate over every
depot (docs/config.md)."""
MAX_RANGE_CELLS = 1 << 28
"""The most entries (depots × action candidates × depots) of the flight-range table a
study area plans with, one byte each: 4,096 depots with 16 candidates each, a window
set up in seconds; a larger table would take gigabytes and minutes (docs/config.md)."""
BOUND_LABELS = 500_000
"""Labels the window bound's search makes at most by default (``[plan] bound_labels``):
seconds of CPU on a 150-request window."""

MAX_EPISODES = 10_000_000
"""The most training episodes (days) one run takes: a year of them a day for decades."""


def check_range_table(
    n_depots: int, n_actions: int, names: tuple[str, str] = ("n_depots", "n_actions")
) -> None:
    """Refuse (``ValueError``) depots and action candidates whose flight-range table
    (:func:`marops_cli.plans.ranges.range_table`) would exceed :data:`MAX_RANGE_CELLS`;
    ``names``: the settings that gave the two counts, as the message names them ("":
    none, a depots file's count)."""
    cells = n_depots * min(n_actions, n_depots) * n_depots
    if cells > MAX_RANGE_CELLS:
        most = max(1, MAX_RANGE_CELLS // (n_depots * n_depots))
        said = [f" ({name})" if name else "" for name in names]
        raise ValueError(
            f"{n_depots} depots{said[0]} with {n_actions} action candidates each"
            f"{said[1]} make a flight-range table of {cells:,} entries, more than the "
            f"{MAX_RANGE_CELLS:,} one study area plans with: at most {most} candidates for "
            f"{n_depots} depots (docs/config.md)"
        )


class _Stage(BaseModel):
    # Every number is finite (no inf, no NaN) and in the range docs/config.md gives.
    model_config = ConfigDict(extra="forbid", validate_assignment=True, allow_inf_nan=False)


T = TypeVar("T")


def ascii_number(text: str, kind: Callable[[str], T]) -> T:
    """``kind(text)`` (``int`` or ``float``) of a number written in ASCII: ``int`` and
    ``float`` alone also read Arabic-Indic and full-width digits, which the options of
    one value (pydantic's) refuse; ``ValueError`` otherwise, as ``kind``'s own."""
    if not text.isascii():
        raise ValueError(f"not in ASCII digits: {text!r}")
    return kind(text)


def _parse_hhmm(value: str) -> int:
    """``"09:00"`` -> seconds after midnight (ASCII digits: ``int`` alone also took
    ``"٠٩:٠٠"``, ``"+9:0_0"``)."""
    match = re.fullmatch(r"([0-9]{1,2}):([0-9]{2})", value)
    if match is None:
        raise ValueError(f"expected a time of day HH:MM, got {value!r}")
    h, m = int(match[1]), int(match[2])
    if not (0 <= h <= 24 and 0 <= m < 60) or h * 60 + m > 24 * 60:
        raise ValueError(f"expected a time of day HH:MM, got {value!r}")
    return h * 3600 + m * 60


class DataConfig(_Stage):
    """Reading a LaDe export and preparing days (docs/method.md §1)."""

    year: int = Field(2022, ge=1970, le=2100, description="year of the MM-DD times")
    size_km: float = Field(10.0, gt=0, le=200, description="side of the study-area square")
    center: tuple[float, float] | None = Field(
        None, description="study-area centre (lng, lat); default: the densest square"
    )
    grid_m: float = Field(
        250.0, ge=10, le=10_000, description="grid step used to find the densest square"
    )
    service_start: str = Field("09:00", description="start of service hours, HH:MM")
    service_end: str = Field("17:00", description="end of service hours, HH:MM")
    window_min: float | None = Field(
        None, ge=1, le=24 * 60, description="window length in minutes (default 30)"
    )
    windows: int | None = Field(
        None,
        ge=1,
        le=24 * 60,
        description="number of windows over service hours (sets the length)",
    )
    area: Literal["square", "hubs"] = Field(
        "hubs",
        # Never in dumps: a single area's run identity and metadata are the same bytes
        # whichever the default, and a city's files name its hubs (docs/outputs.md).
        exclude=True,
        description="what a run plans without --depots, --fleet or --hubs: one study square (the "
        "paper's experiment), or hubs placed over the whole export, each with its own "
        "depots and share of the fleet (docs/method.md §1.1)",
    )
    hub_min_share: float = Field(
        0.01,
        ge=0.004,  # each hub adds this share: at most 250 hubs, within MAX_HUBS (256)
        le=0.5,
        exclude=True,  # the hubs it places are in a city's files
        description='with area = "hubs": hubs are placed while the next one adds at '
        "least this share of the orders",
    )
    strict: bool = Field(False, description="treat any dropped row as an error")
    tz: str = Field(
        "Asia/Shanghai", description="time zone of the file's local times (LaDe: Shanghai)"
    )
    weight_median_kg: float = Field(0.5, gt=0, le=500)
    weight_sigma: float = Field(0.6, ge=0, le=5)
    weight_min_kg: float = Field(0.1, gt=0, le=500)
    weight_max_kg: float = Field(2.5, gt=0, le=500)

    @field_validator("center")
    @classmethod
    def _check_center(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and not (-180 <= v[0] <= 180 and -90 <= v[1] <= 90):
            raise ValueError(f"expected (lng, lat) within -180..180, -90..90, got {v}")
        return v

    @field_validator("tz")
    @classmethod
    def _check_tz(cls, v: str) -> str:
        from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

        try:
            ZoneInfo(v)
        except (ZoneInfoNotFoundError, ValueError, OSError):  # OSError: a name too long
            raise ValueError(
                f"unknown time zone {v!r} (an IANA name, e.g. Asia/Shanghai)"
            ) from None
        return v

    @field_validator("service_start", "service_end")
    @classmethod
    def _check_hhmm(cls, v: str) -> str:
        _parse_hhmm(v)
        return v

    @model_validator(mode="after")
    def _check_span(self) -> DataConfig:
        if self.service_end_s <= self.service_start_s:
            raise ValueError("expected service_end after service_start")
        if self.window_min is not None and self.windows is not None:
            span = self.window_min * 60 * self.windows
            if abs(span - self.span_s) > 1e-6:
                raise ValueError("window_min x windows must equal the service hours")
        if self.weight_max_kg < self.weight_min_kg:
            raise ValueError("expected weight_max_kg >= weight_min_kg")
        return self

    @property
    def service_start_s(self) -> int:
        return _parse_hhmm(self.service_start)

    @property
    def service_end_s(self) -> int:
        return _parse_hhmm(self.service_end)

    @property
    def span_s(self) -> int:
        return self.service_end_s - self.service_start_s

    @property
    def window_s(self) -> float:
        if self.windows is not None:
            return self.span_s / self.windows
        return (self.window_min if self.window_min is not None else 30.0) * 60.0

    @property
    def n_windows(self) -> int:
        if self.windows is not None:
            return self.windows
        return max(1, int(round(self.span_s / self.window_s)))


class SegmentConfig(_Stage):
    """Depots and service areas (docs/method.md §2)."""

    method: Literal["kmeans", "squares"] = Field("kmeans", description="segmentation method")
    n_depots: int = Field(16, ge=1, le=MAX_DEPOTS, description="number of depots / service areas")
    n_actions: int = Field(
        4, ge=1, le=4096, description="action candidates per depot (itself first)"
    )
    seed: int = Field(0, ge=0, le=MAX_SEED, description="k-means random_state")
    n_init: int = Field(4, ge=1, le=1000, description="k-means restarts")

    @model_validator(mode="after")
    def _check(self) -> SegmentConfig:
        check_range_table(self.n_depots, self.n_actions)
        if self.method == "squares":
            side = round(self.n_depots**0.5)
            if side * side != self.n_depots:
                raise ValueError(
                    "expected a square number of depots for the squares method, "
                    f"got {self.n_depots}"
                )
        return self


class EnergyConfig(_Stage):
    """Drone parameters (docs/method.md §3)."""

    body_kg: float = Field(2.0, gt=0, le=500)
    battery_kg: float = Field(1.0, gt=0, le=500)
    rotor_diameter_m: float = Field(0.5, ge=0.01, le=10)
    rotors: int = Field(4, ge=1, le=32)
    # Lower bounds well above 0: a speed or efficiency of 1e-310 is "positive" yet makes
    # the energy of any flight overflow to inf and nan.
    speed_ms: float = Field(10.0, ge=0.1, le=100, description="ground speed = airspeed (no wind)")
    efficiency: float = Field(0.8, ge=0.01, le=1)
    air_density: float = Field(1.225, ge=0.1, le=2)
    g: float = Field(9.81, ge=1, le=30)
    cda_m2: float = Field(0.092951, ge=0, le=10, description="drag area of body and battery")
    parcel_cda_m2: float = Field(0.0, ge=0, le=1, description="extra drag area per kg of parcels")
    max_payload_kg: float = Field(2.5, gt=0, le=500)
    battery_j: float = Field(225_000.0, gt=0, le=100e6, description="battery capacity in joules")
    reserve: float = Field(0.25, ge=0, lt=1, description="fraction of capacity kept unused")
    table_step_kg: float = Field(0.001, ge=1e-4, le=0.1, description="payload lookup-table step")

    @property
    def usable_j(self) -> float:
        return self.battery_j * (1.0 - self.reserve)


class PlanConfig(_Stage):
    """Flight range, candidate plans and plan selection (docs/method.md)."""

    coverage: float = Field(0.25, gt=0, le=1, description="share of service areas in a range")
    planner: Literal["pool", "subsets"] = Field(
        "pool",
        description="candidate plans: pool (many constructed and improved routes per drone) "
        "or subsets (the paper: every subset of the M-hat most delayed requests)",
    )
    range: Literal["reach", "areas"] = Field(
        "reach",
        description="requests a flight-range drone may serve with the pool planner: reach "
        "(any it can serve and still land within the battery) or areas (the paper's range: "
        "start, destination and the areas nearest their midpoint)",
    )
    landing: Literal["destination", "nearest"] = Field(
        "destination",
        description="where a flight-range route lands: the action's destination depot, or the "
        "depot nearest its last customer (pool planner)",
    )
    pool_candidates: int = Field(
        80, ge=1, le=500, description="pool planner: requests considered per drone"
    )
    pool_iterations: int = Field(
        240, ge=0, le=100_000, description="pool planner: ruin-and-recreate steps per window"
    )
    pool_urgency: float = Field(
        0.5,
        ge=0,
        le=48,
        description="pool planner: a request already due counts this many windows of delay "
        "more when routes are built (postponing it one window adds one; 0 = off); the "
        "selection judges routes by the window objective alone",
    )
    wait_credit: float = Field(
        1.0,
        ge=0,
        le=10,
        description="pool planner: each request's prize counts this share of its cheapest "
        "detour (there and back from its nearest request or depot), which waiting would not "
        "save, when routes are built and chosen (0 = off); J and G stay the window "
        "objective's",
    )
    pack_price: float = Field(
        0.0,
        ge=0,
        le=1,
        description="pool planner: each loaded leg is priced this share of the way from its "
        "load's energy per metre to the full payload's when routes are built and chosen, so "
        "payload a route leaves unused costs energy (0 = off); J, G and the energies flown "
        "stay exact",
    )
    serve_h: float = Field(
        0.0,
        ge=0,
        le=24,
        description="pool planner: hours of delay every pending request's prize counts more "
        "when routes are built and chosen, a delivery worth more beside its delay (0 = off); "
        "J and G stay the window objective's",
    )
    night_h: float | None = Field(
        None,
        ge=0,
        le=24,
        description="pool planner: in the day's last window a request left unserved waits "
        "the night for the next day's first window: its prize counts these hours more when "
        "routes are built and chosen (None: 24 h less the service hours; 0 = off); J and G "
        "stay the window objective's",
    )
    pyvrp_iterations: int = Field(
        0,
        ge=0,
        le=1_000_000,
        description="pool planner: iterations of PyVRP per window whose routes join the pool "
        "(0 = off; needs the pyvrp extra; an iteration count keeps results machine-independent)",
    )
    max_parcels: int = Field(
        5, ge=1, le=12, description="M-hat: candidates per drone (subsets planner)"
    )
    ordering: Literal["exact", "greedy"] = Field("exact", description="visiting order")
    candidates: Literal["draft", "top"] = Field(
        "draft",
        description="how drones pick candidates: draft (take turns claiming the most delayed "
        "unclaimed request in range, then top up) or top (paper: each its own M-hat most delayed)",
    )
    ties: Literal["nearest", "due"] = Field(
        "nearest",
        description="order among equally delayed requests: nearest (nearer the drone's depot "
        "first, then earlier due) or due (the paper: earlier due first, then nearer)",
    )
    alpha: float = Field(0.5, ge=0.001, le=1, description="trade-off weight: energy vs delay")
    solver: Literal["highs", "cvxpy", "greedy"] = Field(
        "highs",
        description="plan selection: highs (the boolean program passed to HiGHS directly), "
        "cvxpy (the same program modelled in cvxpy, solved by HiGHS) or greedy",
    )
    time_limit_s: float = Field(2.0, gt=0, le=3600, description="solver time limit per window")
    strict_cover: bool = Field(False, description="paper's exact cover when feasible")
    bound: bool = Field(
        False,
        # Left out of dumps while off, so run identities and metadata stay as they were.
        exclude_if=lambda on: not on,
        description="after planning, prove an upper bound on the window objective G by "
        "column generation over every feasible route, fly the best plan its routes give "
        "when better than the route pool's, and record the plan's gap to the bound",
    )
    bound_labels: int = Field(
        BOUND_LABELS,
        ge=1_000,
        le=100_000_000,
        # Left out of dumps at its default, so run identities and metadata stay as they were.
        exclude_if=lambda n: n == BOUND_LABELS,
        description="with bound = true: labels the bound's search makes at most per window "
        "(a count, so the bound is the same on any machine; more: a tighter bound on busy "
        "windows, at about 14 µs of CPU a label)",
    )


class SimConfig(_Stage):
    """Day replay (docs/method.md §5)."""

    drones: int = Field(8, ge=1, le=MAX_DRONES, description="fleet size")
    city_drones: int | None = Field(
        None,
        ge=1,
        le=256 * MAX_DRONES,  # segment/hubs.py MAX_HUBS hubs of MAX_DRONES
        exclude_if=lambda n: n is None,
        description="over hubs: the city's fleet, shared out over the hubs by their demand "
        "(docs/method.md §1.1); None = drones × the number of hubs",
    )
    policy: str | None = Field(
        None,
        description="flight-range policy (stay, random, greedy, global, torchscript:PATH); "
        "None = the method's own",
    )
    seed: int = Field(0, ge=0, le=MAX_SEED, description="seed for random policies")
    trust_actor: bool = Field(
        False,
        # Left out of dumps while off, so run identities and metadata stay as they were.
        exclude_if=lambda on: not on,
        description="load a TorchScript actor file without a weights file beside it, which "
        "runs its code (--trust-actor; docs/method.md §6)",
    )

    @field_validator("policy")
    @classmethod
    def _check_policy(cls, v: str | None) -> str | None:
        """A policy's name or an actor file's path (the file itself is read later), so
        a misspelt one is named with the config file and key, or the option."""
        why = None if v is None else unknown_policy(v)
        if why is not None:
            raise ValueError(why)
        return v


class OpsConfig(_Stage):
    """The operating model: parcel stock, batteries and chargers, long flights
    (docs/method.md §5.2, "Operating model"). The defaults are the realistic model;
    ``examples/paper.toml`` sets the paper's."""

    stock: Literal["any", "home"] = Field(
        "home",
        description="where parcels wait: home (at the depot of its service area; a drone "
        "carries only its departure depot's parcels) or any (the paper: every parcel at "
        "every depot)",
    )
    batteries_per_depot: int | None = Field(
        2,
        ge=0,
        le=10_000,
        description='charged spare batteries each depot starts the day with; "unlimited" '
        "(None): a charged battery whenever one is needed (the paper)",
    )
    chargers_per_depot: int = Field(
        1,
        ge=0,
        le=10_000,
        description="batteries each depot charges at once (with batteries_per_depot)",
    )
    charge_power_w: float = Field(
        62.5,
        gt=0,
        le=1e6,
        description="charging power of one charger, watts (with batteries_per_depot): the "
        "default 225 kJ battery full in one hour",
    )
    busy: bool = Field(
        True,
        description="a route longer than the window keeps its drone for the windows it spans "
        "(the paper's assumption 5 relaxed); false: every flight ends within its window",
    )

    @field_validator("batteries_per_depot", mode="before")
    @classmethod
    def _unlimited(cls, v: Any) -> Any:
        # TOML has no null: the paper's unlimited swaps are spelled "unlimited".
        return None if v == "unlimited" else v

    @field_validator("chargers_per_depot")
    @classmethod
    def _check_chargers(cls, v: int, info: ValidationInfo) -> int:
        if v == 0 and info.data.get("batteries_per_depot") is not None:
            raise ValueError(
                "expected >= 1 when batteries_per_depot is set (used batteries would never charge)"
            )
        return v

    @classmethod
    def paper_model(cls) -> OpsConfig:
        """The paper's operating model (``examples/paper-ops.toml``)."""
        return cls(stock="any", batteries_per_depot=None, busy=False)

    @property
    def paper(self) -> bool:
        """True when every option is the paper's: the operating model changes nothing."""
        return self.stock == "any" and self.batteries_per_depot is None and not self.busy


BATTERY_PRESETS: dict[str, dict[str, Any]] = {
    "scarce": {"batteries_per_depot": 1, "chargers_per_depot": 1, "charge_power_w": 31.0},
    "default": {},  # the config's own [ops] (OpsConfig's defaults: 2, 1, 62.5 W)
    "ample": {"batteries_per_depot": 4, "chargers_per_depot": 2, "charge_power_w": 125.0},
}
"""The battery regimes (docs/method.md §6.1): the ``[ops]`` options each sets over a
run's config. ``marops train --batteries`` trains on them and ``benchmarks/heldout.py``
judges on them."""


def check_battery_regimes(names: Sequence[str], with_spares: bool, flag: str = "") -> None:
    """Refuse a name of ``names`` that is not a battery regime of :data:`BATTERY_PRESETS`,
    one given twice, and regimes given ``with_spares`` (both set the batteries per
    depot); ``flag`` (the command line's ``--batteries``) starts the line."""
    unknown = [b for b in names if b not in BATTERY_PRESETS]
    if unknown:
        raise InputError(
            f"{flag + ': ' if flag else ''}unknown battery regime {unknown[0]!r} "
            f"(expected {', '.join(BATTERY_PRESETS)})"
        )
    repeated = [b for i, b in enumerate(names) if b in names[:i]]
    if repeated:  # each regime one scenario: a repeat would train on it twice as often
        raise InputError(
            f"{flag + ': ' if flag else ''}battery regime {repeated[0]!r} given twice "
            f"(expected distinct names of {', '.join(BATTERY_PRESETS)})"
        )
    if names and with_spares:
        raise InputError(
            "give batteries per depot (--spares) or battery regimes (--batteries), not both"
        )


def battery_preset(name: str) -> dict[str, Any]:
    """The :func:`override` fields (``ops__...``) of the battery regime ``name``."""
    return {f"ops__{k}": v for k, v in BATTERY_PRESETS[name].items()}


class PlannerConfig(_Stage):
    """Every stage's settings together; loadable from TOML with one table per stage."""

    data: DataConfig = Field(default_factory=DataConfig)
    segment: SegmentConfig = Field(default_factory=SegmentConfig)
    energy: EnergyConfig = Field(default_factory=EnergyConfig)
    plan: PlanConfig = Field(default_factory=PlanConfig)
    sim: SimConfig = Field(default_factory=SimConfig)
    ops: OpsConfig = Field(default_factory=OpsConfig)


STAGES: dict[str, type[_Stage]] = {
    name: field.annotation  # type: ignore[misc]
    for name, field in PlannerConfig.model_fields.items()
}


_WORDS = frozenset({"batteries_per_depot"})
"""Numeric settings that a word may spell (``"unlimited"``)."""


def _kinds(annotation: Any) -> set[type]:
    """The plain types a field's annotation allows (``int | None`` -> {int})."""
    args = typing.get_args(annotation)
    if args and typing.get_origin(annotation) in (typing.Union, types.UnionType):
        return set().union(*(_kinds(a) for a in args if a is not type(None)))
    plain = isinstance(annotation, type) and typing.get_origin(annotation) is None
    return {annotation} if plain else set()


def _item_kinds(annotation: Any) -> set[type]:
    """The plain types the items of a tuple field allow (``tuple[float, float] | None``
    -> {float}); empty for a field that is no tuple."""
    args = typing.get_args(annotation)
    if args and typing.get_origin(annotation) in (typing.Union, types.UnionType):
        return set().union(*(_item_kinds(a) for a in args if a is not type(None)))
    if typing.get_origin(annotation) is tuple:
        return set().union(*(_kinds(a) for a in args if a is not Ellipsis))
    return set()


def check_file_types(
    model: type[BaseModel], table: dict[str, Any], path: str | Path, prefix: str = ""
) -> None:
    """Refuse what validation would otherwise convert quietly in a file's ``table`` for
    ``model``: true or false for a number, text for a number, anything but true or false
    for a switch. The key is named (``prefix`` + its name); unknown keys are left to the
    validation, which names them too."""
    for name, value in table.items():
        field = model.model_fields.get(name)
        if field is None:
            continue
        kinds = _kinds(field.annotation)
        sub = next((k for k in kinds if issubclass(k, BaseModel)), None)
        if sub is not None and isinstance(value, dict):
            check_file_types(sub, value, path, f"{prefix}{name}.")
        elif sub is not None:  # `plan = 3` or `[[plan]]`: no stage's table
            raise SettingError(
                f"expected a table [{prefix}{name}] of settings, got {_shown(value)}",
                key=prefix + name,
                file=path,
            )
        elif kinds == {bool} and not isinstance(value, bool):
            raise SettingError(
                f"expected true or false, got {_shown(value)}", key=prefix + name, file=path
            )
        elif (
            kinds
            and kinds <= {int, float}
            and (isinstance(value, bool) or (isinstance(value, str) and name not in _WORDS))
        ):
            raise SettingError(
                f"expected a number, got {_shown(value)}", key=prefix + name, file=path
            )
        elif (
            isinstance(value, list)
            and _item_kinds(field.annotation) in ({int}, {float}, {int, float})
            and any(isinstance(v, bool | str) for v in value)
        ):
            # A list of numbers (``data.center``): neither true nor "121.4" is one.
            raise SettingError(
                f"expected numbers, got {_shown(value)}", key=prefix + name, file=path
            )


def _shown(value: Any) -> str:
    """A file's value as the file wrote it (true, "2022", 3), clipped."""
    return clipped(json.dumps(value, default=str))


def clipped(text: str, most: int = 60) -> str:
    """``text`` cut to ``most`` characters (an error line stays one readable line)."""
    return text if len(text) <= most else f"{text[: most - 1]}…"


def count(n: int, thing: str) -> str:
    """``1 drone``, ``3 drones``."""
    return f"{n} {thing}" + ("" if n == 1 else "s")


def value_range(stage: str, name: str) -> str | None:
    """The documented range of a numeric setting, as docs/config.md writes it
    (``0 < x ≤ 500``, ``1 ≤ x ≤ 1440``); None for a setting without bounds."""
    return field_range(STAGES[stage].model_fields[name])


def field_range(field: FieldInfo) -> str | None:
    """The range of a numeric field of any settings model, written as :func:`value_range`
    writes it; None for a field without bounds."""
    low = high = ""
    for m in field.metadata:
        for attr, text in (("gt", "{} < "), ("ge", "{} ≤ ")):
            if getattr(m, attr, None) is not None:
                low = text.format(_number(getattr(m, attr)))
        for attr, text in (("lt", " < {}"), ("le", " ≤ {}")):
            if getattr(m, attr, None) is not None:
                high = text.format(_number(getattr(m, attr)))
    return f"{low}x{high}" if low or high else None


def _number(v: float) -> str:
    short = f"{v:g}".replace("e+0", "e").replace("e+", "e")
    if float(short) == v and (not float(v).is_integer() or "e" in short):
        return short  # 0.25, 1e8
    return str(int(v))  # 1440, 4294967295


def option_error(
    exc: ValidationError, model: type[BaseModel], flag: Callable[[str], str]
) -> InputError:
    """The one line naming the command-line option whose value ``model`` refused
    (``flag``: an option's flag, without ``--``, from its field's name): the reason, and
    for a number out of range the value and the range."""
    err = exc.errors()[0]
    name = str(err["loc"][0])
    opt = flag(name)
    msg = f"invalid option --{opt}: {str(err['msg']).removeprefix('Value error, ')}"
    field = model.model_fields.get(name)
    rng = field_range(field) if field is not None else None
    if rng is not None and "input" in err:  # as the planner's options say theirs
        msg = f"{msg}, got {err['input']!r} (expected {rng.replace('x', opt)})"
    return InputError(msg)


def validation_message(exc: ValidationError, names: dict[str, str] | None = None) -> str:
    """``plan.alpha: Input should be …, got 1.5``; ``names`` says what to call a field,
    and its parts (``{"plan.alpha": "--alpha"}``, ``{"data.center": option("center")}``
    names ``data.center.0`` too)."""
    err = exc.errors()[0]
    loc = ".".join(str(p) for p in err["loc"])
    parts = loc.split(".")
    for i in range(len(parts), 0, -1):
        if (name := (names or {}).get(".".join(parts[:i]))) is not None:
            loc = name
            break
    msg = str(err["msg"]).removeprefix("Value error, ")
    if "input" in err and not isinstance(err["input"], dict | list) and ", got " not in msg:
        msg = f"{msg}, got {clipped(repr(err['input']))}"
    path = [str(p) for p in err["loc"]]
    if len(path) >= 2 and path[0] in STAGES and path[1] in STAGES[path[0]].model_fields:
        rng = value_range(path[0], path[1])
        if rng is not None and err["type"] not in ("extra_forbidden", "missing"):
            msg = f"{msg} (expected {rng.replace('x', path[1])}, docs/config.md)"
    return f"{loc}: {msg}" if loc else msg


def load_config(path: str | Path | None) -> PlannerConfig:
    """Load a TOML config (or the defaults when ``path`` is None)."""
    if path is None:
        return PlannerConfig()
    p = Path(path)
    raw = read_document(p, "config file", "toml")
    sim = raw.get("sim")
    if isinstance(sim, dict) and "trust_actor" in sim:
        # A file from elsewhere never makes marops run code (docs/method.md §6): only the
        # person at the command line grants trust to an actor file.
        raise InputError(
            "only the --trust-actor flag can trust an actor file, not a config file",
            file=p,
            column="sim.trust_actor",
        )
    check_file_types(PlannerConfig, raw, p)
    try:
        return PlannerConfig.model_validate(raw)
    except ValidationError as exc:
        raise InputError(f"invalid setting {validation_message(exc)}", file=p) from exc


def sets_key(path: str | Path, key: str) -> bool:
    """Whether the TOML config at ``path`` sets ``key`` (``stage.field``)."""
    stage, _, name = key.partition(".")
    try:
        raw = parse_toml(read_small_text(path, "config"))
    except (OSError, ValueError, InputError):  # UnicodeDecodeError is a ValueError
        return False
    table = raw.get(stage)
    return isinstance(table, dict) and name in table


def override(
    cfg: PlannerConfig, names: dict[str, str] | None = None, **fields: Any
) -> PlannerConfig:
    """Return a copy with ``stage__field=value`` overrides applied (None = keep); an
    invalid value's error calls the field by its name in ``names`` (``stage__field`` ->
    the option that set it, ``option("alpha")`` of marops_cli/errors.py), else
    ``stage.field``."""
    # Every field's value, those left out of dumps (``exclude``) too, so none is lost.
    data = {stage: dict(getattr(cfg, stage)) for stage in type(cfg).model_fields}
    for key, value in fields.items():
        if value is None:
            continue
        stage, _, name = key.partition("__")
        data[stage][name] = value
    try:
        return PlannerConfig.model_validate(data)
    except ValidationError as exc:
        dotted = {k.replace("__", "."): v for k, v in (names or {}).items()}
        # A stage's own check (depots against candidates, say) names the options given
        # of that stage, not the stage.
        for stage in type(cfg).model_fields:
            given = [
                v
                for k, v in (names or {}).items()
                if k.startswith(f"{stage}__") and fields.get(k) is not None
            ]
            if given:
                dotted.setdefault(stage, ", ".join(dict.fromkeys(given)))
        raise InputError(f"invalid option {validation_message(exc, dotted)}") from exc
