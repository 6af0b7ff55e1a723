"""The use cases' config-backed options, declared once: :data:`OPTIONS`, one
:class:`OptionSpec` each (its name, type, help text, environment variable and config
field; its range is the config field's). The commands' flags (marops_cli/cli/options.py),
the Python API's keyword arguments and their checks (marops_cli/api.py) and the
config override (:func:`planner_config`) all derive from the table (docs/decisions.md,
"Adding an option")."""

from __future__ import annotations

import dataclasses
import inspect
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import InputError, option, quoted
from .inputs import parse_center

if TYPE_CHECKING:  # the settings' models load with the first config (not for --help)
    from ..config import PlannerConfig
    from .evaluate import EvaluateConfig

USES = ("segment", "plan_window", "replay_day", "evaluate", "train")
"""The use cases that take options: each is a command (``plan-window``) and, but for
``train``, a function of the Python API (``plan_window``)."""


@dataclass(frozen=True)
class OptionSpec:
    """One option that sets one field of the planner config.

    Its range is the config field's: a value outside is refused by the config's checks,
    naming the option (:func:`planner_config`)."""

    name: str
    """The option's identity: the :func:`planner_config` keyword, and how an error names
    it (``errors.option(name)``)."""
    field: str
    """``stage.field`` of :class:`~marops_cli.config.PlannerConfig`."""
    type: type
    """What its flag takes: ``int``, ``float``, ``str``, or ``bool`` for a switch (off
    unless given)."""
    help: str | Callable[[], str]
    """The help text (with the default in brackets, ``[default: 8]``), or a function
    giving it (a text naming a registry's entries, made when asked)."""
    uses: tuple[str, ...]
    """The use cases (:data:`USES`) that take it."""
    envvar: str | None = None
    """The environment variable its flag reads when not given (the API reads none)."""
    flag: str | None = None
    """Its flag where it is not the name's (``--seed`` for ``segment_seed``)."""
    keyword: str | None = None
    """Its API keyword (and the commands' parameter) where it is not the name."""
    api_type: Any = None
    """What the API takes where more than ``type`` (a pair as well as ``"LNG,LAT"``)."""
    helps: Mapping[str, str] = dataclasses.field(default_factory=dict)
    """Use case -> its own wording of the help text, where one words it otherwise."""

    @property
    def param(self) -> str:
        """The keyword argument (the API's, the command function's parameter)."""
        return self.keyword or self.name

    @property
    def flag_text(self) -> str:
        return self.flag or "--" + self.name.replace("_", "-")

    @property
    def switch(self) -> bool:
        return self.type is bool

    def help_text(self, use: str | None = None) -> str:
        """The help text, as use case ``use`` words it."""
        given: str | Callable[[], str] = self.helps.get(use or "", self.help)
        return given if isinstance(given, str) else given()


def _policy_help() -> str:
    from ..methods import policy_names

    return (
        f"Flight-range policy: {policy_names()}, or a trained actor (PATH.pt, an actor's "
        "weights PATH.safetensors, or torchscript:PATH) [default: the method's own]."
    )


_ALL = ("segment", "plan_window", "replay_day", "evaluate")
_PLANNED = ("plan_window", "replay_day")
_REPLAYED = ("plan_window", "replay_day", "evaluate")

OPTIONS: dict[str, OptionSpec] = {
    spec.name: spec
    for spec in (
        OptionSpec(
            "year",
            "data.year",
            int,
            "Year of the MM-DD times [default: 2022].",
            (*_ALL, "train"),
            envvar="MAROPS_YEAR",
        ),
        OptionSpec(
            "strict", "data.strict", bool, "Make any bad row an error instead of dropping it.", _ALL
        ),
        OptionSpec(
            "tz",
            "data.tz",
            str,
            "Time zone of the data's local times [default: Asia/Shanghai].",
            _PLANNED,
            envvar="MAROPS_TZ",
        ),
        OptionSpec(
            "size_km",
            "data.size_km",
            float,
            "Side of the study-area square in km [default: 10].",
            ("segment",),
        ),
        OptionSpec(
            "center",
            "data.center",
            str,
            "Study-area centre LNG,LAT [default: the densest square].",
            ("segment",),
            api_type=str | tuple[float, float],
        ),
        OptionSpec(
            "area",
            "data.area",
            str,
            "square: one study square (the paper's experiment); hubs: hubs placed over the "
            "whole export, each with its depots and share of the fleet, one folder each "
            "[default: [data] area, hubs; one square with --depots or --fleet].",
            ("replay_day", "evaluate"),
            envvar="MAROPS_AREA",
        ),
        OptionSpec(
            "n_depots",
            "segment.n_depots",
            int,
            "Number of depots / service areas [default: 16].",
            ("segment", "replay_day"),
            helps={"replay_day": "Depots when segmenting here [default: 16]."},
        ),
        OptionSpec(
            "segmentation",
            "segment.method",
            str,
            "kmeans (k-means areas, docs/method.md §2) or squares [default: kmeans].",
            ("segment",),
        ),
        OptionSpec(
            # replay_config: the method's own segmentation unless given
            "segment",
            "segment.method",
            str,
            "kmeans or squares when segmenting here [default: the method's].",
            ("replay_day",),
        ),
        OptionSpec(
            "actions",
            "segment.n_actions",
            int,
            "Action candidates per depot, itself included [default: 4].",
            ("segment",),
        ),
        OptionSpec(
            "segment_seed",
            "segment.seed",
            int,
            "k-means random seed [default: 0].",
            ("segment",),
            flag="--seed",
            keyword="seed",
        ),
        OptionSpec(
            "alpha",
            "plan.alpha",
            float,
            "Trade-off weight in [0.001, 1]: higher saves energy, lower delay [default: 0.5].",
            (*_PLANNED, "train"),
            envvar="MAROPS_ALPHA",
        ),
        OptionSpec(
            "ordering",
            "plan.ordering",
            str,
            "Visiting order: exact (energy-optimal) or greedy (paper) [default: exact].",
            _PLANNED,
        ),
        OptionSpec(
            "strict_cover",
            "plan.strict_cover",
            bool,
            "The paper's exact cover of all candidates when feasible.",
            ("plan_window",),
        ),
        OptionSpec(
            "drones",
            "sim.drones",
            int,
            "Fleet size [default: 8].",
            _PLANNED,
            envvar="MAROPS_DRONES",
        ),
        OptionSpec(
            "city_drones",
            "sim.city_drones",
            int,
            "Over hubs: the city's fleet, shared out by the hubs' demand "
            "[default: --drones per hub].",
            ("replay_day", "evaluate"),
        ),
        OptionSpec(
            "seed",
            "sim.seed",
            int,
            "Seed for random policies [default: 0].",
            _REPLAYED,
            envvar="MAROPS_SEED",
        ),
        OptionSpec("policy", "sim.policy", str, _policy_help, _PLANNED, api_type=str | Path),
        OptionSpec(
            "trust_actor",
            "sim.trust_actor",
            bool,
            "Load a TorchScript actor (.pt) that has no weights file (.safetensors) beside "
            "it: this runs code of the file, so only for a file whose author you trust "
            "(docs/method.md §6).",
            _REPLAYED,
        ),
    )
}
"""Option name -> its spec: every option that sets a planner config field, in the order
a command lists those it does not place itself."""


def options_for(use: str) -> list[OptionSpec]:
    """The options use case ``use`` takes, in the table's order."""
    return [spec for spec in OPTIONS.values() if use in spec.uses]


@contextmanager
def registered(spec: OptionSpec) -> Iterator[OptionSpec]:
    """``spec`` in the table while the block runs (a script's or a test's own option)."""
    if spec.name in OPTIONS:
        raise ValueError(f"an option {spec.name!r} is in the table already")
    OPTIONS[spec.name] = spec
    try:
        yield spec
    finally:
        del OPTIONS[spec.name]


# --- signatures with the table's options -------------------------------------------
# A command's function and an API function take their use case's options gathered in one
# keyword-only parameter, ``options`` (name -> value); their signature as callers see it
# (``__signature__``: Typer reads it, so does ``help()``) is theirs with the table's
# options in, made anew from the table each time it is asked.


class LiveSignature(inspect.Signature):
    """A signature made anew (``make()``) each time it is read: a function's
    ``__signature__`` that follows the table."""

    __slots__ = ("_make",)

    def __init__(self, make: Callable[[], inspect.Signature]) -> None:  # no fixed parameters
        self._make = make

    @property
    def parameters(self) -> Mapping[str, inspect.Parameter]:  # type: ignore[override]
        return self._make().parameters

    @property
    def return_annotation(self) -> Any:
        return self._make().return_annotation


def with_options(
    own: inspect.Signature,
    use: str,
    parameter: Callable[[OptionSpec], inspect.Parameter],
    before: Sequence[str],
) -> inspect.Signature:
    """``own`` (with its ``options`` parameter) as callers see it: a parameter named after
    one of ``use``'s options becomes the table's (``parameter(spec)``: annotation and
    default; where it stands places it in a command's help), and the options it does not
    name go in before the first of ``before`` it has (else at the end)."""
    specs = {spec.param: spec for spec in options_for(use)}
    params = [
        parameter(specs[p.name]) if p.name in specs else p
        for p in own.parameters.values()
        if p.name != "options"
    ]
    placed = {p.name for p in params}
    added = [parameter(spec) for spec in specs.values() if spec.param not in placed]
    names = [p.name for p in params]
    at = next((names.index(b) for b in before if b in names), len(params))
    return own.replace(parameters=[*params[:at], *added, *params[at:]])


def split_options(
    use: str, kwargs: Mapping[str, Any], own: inspect.Signature
) -> tuple[dict[str, Any], dict[str, Any]]:
    """A call's keyword arguments as ``(own, options)``: those ``own``'s parameters take
    (the table's options it places itself too), and every option of ``use`` given, by
    name (``segmentation``: ``method=`` of ``segment``)."""
    mine = {k: v for k, v in kwargs.items() if k in own.parameters and k != "options"}
    options = {spec.name: kwargs[spec.param] for spec in options_for(use) if spec.param in kwargs}
    return mine, options


EXCLUSIVE: tuple[tuple[str, str, str], ...] = (
    ("drones", "fleet", "a fleet file's drones are the fleet"),
    ("n_depots", "depots", "a depots file's depots are the depots"),
    ("segment", "depots", "a depots file's depots are the depots"),
    ("area=hubs", "depots", "a depots file's depots are one study square"),
    ("area=hubs", "fleet", "a fleet file's drones fly one study square"),
    ("city_drones", "depots", "a depots file's depots are one study square"),
    ("city_drones", "fleet", "a fleet file's drones fly one study square"),
    ("city_drones", "area=square", "one study square has no city to share drones over"),
)
"""Pairs of options of which one, given, makes the other unused (``(option, option,
why)``; ``name=value``: that option given that value): given both, the second would win
unsaid, so both are refused (a config file's value under an option is the config's
precedence, and no contradiction)."""


def refuse_both(given: Mapping[str, Any]) -> None:
    """Refuse, before any work, two options of a pair of :data:`EXCLUSIVE` both given
    (``given``: the options the caller gave, name -> value: on the command line, or as
    the API's keywords)."""

    def named(spec: str) -> str | None:
        name, _, value = spec.partition("=")
        if name not in given or value and str(given[name]).strip().lower() != value:
            return None
        return f"{option(name)} {value}" if value else option(name)

    for first, second, why in EXCLUSIVE:
        a, b = named(first), named(second)
        if a and b:
            raise InputError(f"give at most one of {a} or {b}: {why}, so {a} would be left unused")


HUBS_READ = ("year", "size_km", "strict")
"""The options ``segment`` reads when it tiles a city into hubs: it places the study
areas itself, so one study area's others are refused (``app.segment.refuse_with_hubs``)."""


def hubs_options(options: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``segment``'s options with hubs as ``(read, refused)``: :data:`HUBS_READ` and the
    others."""
    read = {k: v for k, v in options.items() if k in HUBS_READ}
    return read, {k: v for k, v in options.items() if k not in HUBS_READ}


# --- the config --------------------------------------------------------------------


def planner_config(
    config: str | Path | None, *, flies_policy: bool = True, **options: Any
) -> PlannerConfig:
    """The TOML config (or the defaults) with the options (:data:`OPTIONS`, by name)
    applied on top: an option left unset (None) or a switch left off (False) keeps the
    config's value; ``center`` may be ``"LNG,LAT"`` text, a text option a path. An
    invalid value is an error naming its option (``--alpha`` on the command line,
    ``alpha`` in the API: marops_cli/errors.py). An unknown option name is a
    ``TypeError``. ``flies_policy``: the run flies ``sim.policy`` (not evaluate, whose
    actors are its own options), so ``trust_actor`` must not reach an actor file only
    the config names."""
    from ..config import load_config, override

    unknown = set(options) - set(OPTIONS)
    if unknown:
        raise TypeError(f"not planner options: {sorted(unknown)}")
    if isinstance(options.get("center"), str):  # a bad centre is named before the file is read
        options["center"] = parse_center(options["center"])
    overrides = {
        OPTIONS[name].field.replace(".", "__"): _given(value) for name, value in options.items()
    }
    names = {OPTIONS[name].field.replace(".", "__"): option(name) for name in options}
    loaded = load_config(Path(config) if config is not None else None)
    if flies_policy:
        _refuse_trust_for_config_actor(loaded, config, options)
    cfg = override(loaded, names, **overrides)
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


def _refuse_trust_for_config_actor(
    loaded: PlannerConfig, config: str | Path | None, options: Mapping[str, Any]
) -> None:
    """Refuse ``--trust-actor`` for an actor file that only the config names (``[sim]
    policy``): the flag trusts the code of an actor the person at the command line
    chose, and a config file from elsewhere would otherwise choose which code runs
    (docs/method.md §6, "Trust model of actor files")."""
    spec = loaded.sim.policy
    if not options.get("trust_actor") or options.get("policy") is not None or not spec:
        return
    from ..policies.registry import PolicySpec

    if PolicySpec.parse(spec).kind != "torchscript":  # a rule or a shipped actor by name
        return
    raise InputError(
        f"{option('trust_actor')} trusts an actor named by {option('policy')}, not one a "
        f"config file names ({quoted(spec)}): give it as {option('policy')} to trust its code",
        file=config,
        column="sim.policy",
    )


def _given(value: Any) -> Any:
    """An option's value as an override: None (keep the config's) for a switch left off,
    a path as its text."""
    if isinstance(value, bool):
        return value or None
    return os.fspath(value) if isinstance(value, os.PathLike) else value


def evaluate_config(
    config: str | Path | None,
    options: Mapping[str, Any],
    *,
    methods: str | None,
    dates: str | None,
    split: str | None,
    hubs: str | Path | None,
    policy: str | Path | None,
    mappo_policy: str | Path | None,
    **fields: Any,
) -> EvaluateConfig:
    """``evaluate``'s settings, for the command and the API alike: the planner config of
    its options, the methods (``"a,b"``), its days (``dates``, or the ``split``'s; not
    both), the hubs of a hubs file, the trained actors replacing the shipped ones, and
    the other :class:`~marops_cli.app.evaluate.EvaluateConfig` fields as given."""
    from ..data.dates import parse_days
    from ..segment.hubs import load_hubs
    from .evaluate import EvaluateConfig, actor_paths, method_list

    cfg = planner_config(config, flies_policy=False, **options)
    hub_list = load_hubs(hubs, cfg.data) if hubs is not None else None
    # --dates "" (an empty list from a script) is an error, not the split's days.
    days = parse_days(dates, cfg.data.year, option("dates")) if dates is not None else None
    if dates is not None and split is not None:
        raise InputError(f"give at most one of {option('dates')} or {option('split')}")
    return EvaluateConfig(
        cfg,
        method_list(methods),
        days=days,
        split=split if split is not None else "test",
        hubs=hub_list,
        actors=actor_paths(policy or None, mappo_policy or None),
        **fields,
    )
