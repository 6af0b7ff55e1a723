"""The flight-range policy protocol and the window view that policies read."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, Protocol, runtime_checkable

import numpy as np

from ..errors import InputError
from ..plans.select import Selector
from ..plans.view import WindowView

if TYPE_CHECKING:
    from ..config import PlannerConfig

MAX_WEIGHT = 1e6
"""The largest magnitude of a weight in an actor's weights file (docs/method.md §6,
"Trust model of actor files"): trained weights are of order 1 (the shipped actors' under
2), and far beyond, a logit or a landing score overflows to infinity."""


def check_weight_range(largest: float, file: Path, tensor: str) -> None:
    """Refuse a weights file whose tensor ``tensor`` holds a weight of magnitude
    ``largest`` beyond :data:`MAX_WEIGHT`, naming the file and the tensor."""
    if largest > MAX_WEIGHT:
        raise InputError(
            f"holds a weight of magnitude {largest:.3g}, beyond the {MAX_WEIGHT:.0e} an "
            "actor's weights may reach (trained weights are of order 1)",
            file=file,
            column=tensor,
        )


_DTYPE_BYTES = {
    "BOOL": 1, "U8": 1, "I8": 1, "F8_E5M2": 1, "F8_E4M3": 1,
    "I16": 2, "U16": 2, "F16": 2, "BF16": 2,
    "I32": 4, "U32": 4, "F32": 4,
    "I64": 8, "U64": 8, "F64": 8,
}  # fmt: skip
"""Bytes a value of each safetensors dtype takes (a dtype not listed is not checked for
size: a reader of actors takes float32 only, and refuses any other by name)."""


@dataclass(frozen=True)
class Tensors:
    """A safetensors file read and its JSON header parsed once (:func:`read_tensors`):
    each tensor's ``dtype`` and ``shape`` from the header, its values on demand."""

    path: Path
    header: dict[str, dict[str, Any]]
    data: bytes
    """The bytes after the header: the tensors' values, at their ``data_offsets``."""

    def names(self) -> set[str]:
        return set(self.header)

    def dtype(self, name: str) -> str:
        return str(self.header[name]["dtype"])

    def shape(self, name: str) -> tuple[int, ...]:
        return tuple(self.header[name]["shape"])

    def float32(self, name: str) -> np.ndarray:
        """The F32 tensor ``name`` (checked by the caller) as a new native float32 array."""
        begin, end = self.header[name]["data_offsets"]
        values = np.frombuffer(self.data, dtype="<f4", count=(end - begin) // 4, offset=begin)
        return values.astype(np.float32).reshape(self.shape(name))


def read_tensors(path: Path, limit: int) -> Tensors:
    """The safetensors file ``path`` of at most ``limit`` bytes, read once and its
    header parsed once: a file that is none (too short, a header past its end, not a JSON
    object, or a key given twice, which every other JSON marops reads refuses and the
    safetensors reader kept the last of unsaid), or whose tensors do not fill its data
    exactly one after the other, each of its shape's size, is one line naming it. Nothing
    of the file runs: a safetensors file is a JSON header and raw numbers."""
    from ..data.jsonfile import first_line, parse_json

    try:
        with open(path, "rb") as f:
            raw = f.read(limit + 1)  # never more, were the file to grow after its size was read
    except OSError as exc:
        raise InputError(f"not a safetensors weights file ({first_line(exc)})", file=path) from None
    if len(raw) > limit:
        raise InputError(f"larger than {limit:,} bytes, more than its actor's weights", file=path)
    size = int.from_bytes(raw[:8], "little") if len(raw) >= 8 else -1
    try:
        if not 0 < size <= len(raw) - 8:
            raise ValueError("no header of a length within the file")
        header = parse_json(raw[8 : 8 + size].decode("utf-8"))
        if not isinstance(header, dict):
            raise ValueError("its header is not a JSON object")
        meta = header.pop("__metadata__", None)
        if meta is not None and not (
            isinstance(meta, dict) and all(isinstance(v, str) for v in meta.values())
        ):
            raise ValueError("its __metadata__ is not an object of texts")
        data = raw[8 + size :]
        _check_layout(header, len(data))
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"not a safetensors weights file ({first_line(exc)})", file=path) from None
    return Tensors(path, header, data)


def _check_layout(header: dict[str, Any], length: int) -> None:
    """Raise ``ValueError`` unless each tensor of ``header`` names its dtype, shape and
    data offsets, and the tensors fill the ``length`` bytes of data one after the other,
    each as many bytes as its shape and dtype take (as the safetensors reader checks)."""
    spans = []
    for name, info in header.items():
        entry: dict[str, Any] = info if isinstance(info, dict) else {}
        dtype: Any = entry.get("dtype")
        shape: Any = entry.get("shape")
        offsets: Any = entry.get("data_offsets")
        lists = isinstance(shape, list) and isinstance(offsets, list) and len(offsets) == 2
        counts: list[Any] = [*shape, *offsets] if lists else []
        if not isinstance(dtype, str) or not lists or not _counts(counts):
            raise ValueError(f"the tensor {name!r} has no dtype, shape and data offsets")
        begin, end = counts[-2:]
        width = _DTYPE_BYTES.get(dtype)
        if end < begin or (width is not None and end - begin != width * math.prod(counts[:-2])):
            raise ValueError(f"the tensor {name!r}'s data offsets do not fit its shape")
        spans.append((begin, end))
    at = 0
    for begin, end in sorted(spans):
        if begin != at:
            raise ValueError("the tensors' data offsets leave a gap or overlap")
        at = end
    if at != length:
        raise ValueError(f"the tensors take {at} bytes of data, the file holds {length}")


def _counts(values: list[Any]) -> bool:
    """Whether every value is a whole number of at least 0 (true is none)."""
    return all(type(v) is int and v >= 0 for v in values)


SLOT_PLANNER = "subsets"
"""The planner whose plans a policy that picks plans by slot ranks (the MAPPO baseline:
the paper's subset plans, docs/method.md §4.5)."""


@dataclass(frozen=True)
class SlotActions:
    """One window's choices of a policy that picks the plans itself (the MAPPO baseline):
    each drone's action, as :meth:`Policy.act` returns them, and the plan slot it picked
    (:class:`~.direct.SlotSelector` flies it)."""

    actions: np.ndarray
    slots: np.ndarray


@runtime_checkable
class Policy(Protocol):
    """Chooses each drone's destination among its depot's action candidates.

    ``scope`` is ``"range"`` for the paper's flight ranges and ``"global"`` for the
    whole-map baseline (the planner then ignores the actions). A policy that picks the
    plans itself (the MAPPO baseline) brings its ``selector`` and the ``planner`` whose
    plans it ranks; others leave both None. ``identity`` is what output files record
    (the actor file, or the policy's name).
    """

    name: str
    scope: Literal["range", "global"]
    planner: str | None
    selector: Selector | None

    @property
    def identity(self) -> str | Path: ...

    def configure(self, cfg: PlannerConfig) -> None:
        """Receive the run's planner settings (a policy that prices plans needs them)."""
        ...

    def reset(self, seed: int) -> None:
        """Start a new day (recurrent state, random streams)."""
        ...

    def act(self, view: WindowView) -> np.ndarray | SlotActions:
        """Action index (0 = stay) for every drone, shape ``(U,)``; a policy that picks
        the plans itself adds each drone's plan slot (:class:`SlotActions`)."""
        ...


class PolicyBase:
    """The protocol's defaults: a flight-range policy that needs no settings."""

    name: str = "policy"
    scope: Literal["range", "global"] = "range"
    planner: str | None = None
    selector: Selector | None = None

    @property
    def identity(self) -> str | Path:
        return self.name

    def configure(self, cfg: PlannerConfig) -> None:
        return None

    def reset(self, seed: int) -> None:
        return None


def start_day(policy: Policy, cfg: PlannerConfig, seed: int) -> None:
    """Hand a policy the run's planner settings and start its day."""
    policy.configure(cfg)
    policy.reset(seed)
