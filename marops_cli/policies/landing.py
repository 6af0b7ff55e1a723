"""The landing actor: a learned score of each destination under the operating model
(docs/method.md §6.1, "The landing actor").

Under the realistic operating model a drone carries only the parcels stocked at the depot
it departs from and needs a charged battery there, so where it lands decides what it can
do next window. The landing actor scores each of a drone's destinations (its depot's
action candidates) by a weighted sum of the features below. Its weights are learned on
the day's return (``marops train --algorithm es``, :mod:`marops_cli.rl.es`), starting
from :data:`BACKLOG_WEIGHTS`, the ``backlog`` rule's score.

Three kinds of actor, told apart by their number of weights (and their file's format):

* **joint** (16 weights, ``marops-landing-actor/2``, the shipped one): the ready drones
  are assigned to landing slots together (``scipy.optimize.linear_sum_assignment``,
  maximising the total score), slot j of depot d meaning "the (j + 1)-th ready drone
  to land at d", scored with j more drones there (a depot has one slot per ready drone
  that has it among its reachable destinations); every drone also has the free landing
  (nearest its last customer), scored as staying in its depot's first slot plus weights
  12–15 × (1, time of day, the backlog score of staying, drones per area). So the drone
  nearest a depot that needs one is the one that flies there, and two drones do not
  both leave for the same depot unless it pays for both. With weights 12–15 at 0 a
  second or later drone that would stay at a depot where parcels wait lands free
  instead (staying there scores less with each drone).
* **joint, reading the situation** (22 weights, ``marops-landing-actor/3``): the joint
  actor with six more destination features (12–17 below) that let one score stay where
  drones are many or batteries short and spread where drones are few, and weigh a
  flight's distance by the run's α; its free landing is weights 18–21.
* **joint, reading the situation and the flow rule** (25 weights,
  ``marops-landing-actor/4``): the ``/3`` actor with three more features (18–20 below)
  that read the ``flow`` rule's plan of the window (:class:`~.rules.FlowPolicy`): one
  weight can make it fly the flow rule's landings, the situation's weights say where; its
  free landing is weights 21–24, and scores staying without features 18–20 (the flow rule
  never lands free).
* **sequential** (12 weights, ``marops-landing-actor/1``): drones choose one after
  another, as :class:`~.rules.BacklogPolicy` does, each seeing where the drones before
  it chose to land; with :data:`BACKLOG_WEIGHTS` it is exactly the ``backlog`` rule.

A joint actor's assignment is followed by two steps (docs/method.md §6.1): a depot whose
parcels have waited a window with no drone coming calls an idle one, and every drone
the actor keeps at its depot is the ``flow`` rule's to move (its min-cost flow of those
drones, the others counted where they land).

Features of destination d for a drone at depot s (``there``: drones at d that have not
chosen yet, plus those that chose to land at d; the drone itself is not counted while it
chooses; value: Σ (1 + delay h) of the parcels waiting at d; ``lg`` = log1p):

0. lg value at d
1. lg there
2. lg (value / (1 + there)): the backlog score
3. lg parcels waiting at d
4. distance s → d, km
5. lg requests expected in d's area over the next two windows (the history days'
   arrival profile, ``depots.arrivals``; 0 without one)
6. lg (5 / (1 + there)): expected demand per drone
7. lg charged spare batteries at d (3 when swaps are unlimited)
8. lg batteries on charge at d
9. 1 when d is s (stay)
10. time of day (fraction of the day's windows gone) × feature 2
11. time of day × feature 4

The situation's features (format ``/3`` only; ``density``: lg (1 + drones per area),
``load``: lg (1 + parcels waiting per drone), α: the run's trade-off):

12. density × feature 9 (stay where drones are many)
13. density × feature 4 (fly far where drones are few)
14. 1 when d is not s and d has no charged spare (the drone would strand there)
15. load × feature 9
16. α × feature 4 (a flight's energy, priced by α)
17. α × feature 9

The flow rule's features (format ``/4`` only; ``flow(d)``: how many of the ready drones the
``flow`` rule lands at d this window, staying ones included; slot j of d is the (j + 1)-th
ready drone to land there):

18. 1 when the slot is one the flow rule fills (j < flow(d))
19. density × feature 18
20. load × feature 18

The file format is data only: ``NAME.safetensors`` holds one float32 tensor ``weight`` of
shape ``(16,)`` (or ``(22,)``, ``(25,)``, ``(12,)``), its sidecar ``NAME.json`` says
``format`` and the operating model it was trained for (docs/method.md §6, "Trust model
of actor files").
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar, Literal, NamedTuple

import numpy as np

from ..data.jsonfile import refuse_misspelt_keys
from ..errors import InputError, option, quoted
from ..plans.view import FREE
from .base import WindowView, check_weight_range, read_tensors
from .rules import EnergyAware, FlowPolicy, reachable, waiting_per_depot

if TYPE_CHECKING:
    from ..config import OpsConfig, PlannerConfig

__all__ = [
    "BACKLOG_WEIGHTS",
    "CONTEXT_FEATURES",
    "CONTEXT_FORMAT",
    "FEATURES",
    "FREE_FEATURES",
    "JOINT_START",
    "CONTEXT_START",
    "FEATURE_SETS",
    "FeatureSet",
    "LANDING_FORMAT",
    "RULE_FEATURES",
    "RULES_FORMAT",
    "RULES_START",
    "LandingActor",
    "check_trained_for",
    "extend_weights",
    "landing_features",
    "operating_model",
]

FEATURES = (
    "value",
    "there",
    "backlog score",
    "parcels",
    "distance km",
    "expected",
    "expected per drone",
    "spares",
    "charging",
    "stay",
    "time x backlog score",
    "time x distance km",
)
"""The features of a destination, in order (the module docstring defines them)."""
N_FEATURES = len(FEATURES)
CONTEXT_FEATURES = (
    "stay x drones per area",
    "distance km x drones per area",
    "strands",
    "stay x parcels per drone",
    "alpha x distance km",
    "alpha x stay",
)
"""The situation's destination features of a ``/3`` actor, in order (module docstring)."""
RULE_FEATURES = ("flow slot", "flow slot x drones per area", "flow slot x parcels per drone")
"""The flow rule's destination features of a ``/4`` actor, in order (module docstring)."""
FREE_FEATURES = ("free", "free x time", "free x backlog score", "free x drones per area")
"""The joint actor's free landing: its weights 12–15 multiply these (module docstring)."""
BACKLOG_WEIGHTS = np.eye(N_FEATURES)[2]
"""The weights that make the sequential landing actor the ``backlog`` rule."""
JOINT_START = np.concatenate([BACKLOG_WEIGHTS, np.zeros(len(FREE_FEATURES))])
"""Where training starts: the backlog score, shared out jointly, the free landing at 0."""
CONTEXT_START = np.concatenate(
    [BACKLOG_WEIGHTS, np.zeros(len(CONTEXT_FEATURES) + len(FREE_FEATURES))]
)
"""Where training a ``/3`` actor starts: the backlog score, every other weight at 0."""
RULES_START = np.concatenate(
    [BACKLOG_WEIGHTS, np.zeros(len(CONTEXT_FEATURES) + len(RULE_FEATURES) + len(FREE_FEATURES))]
)
"""Where training a ``/4`` actor starts (without ``--init``): as a ``/3`` actor's."""
LANDING_FORMAT = "marops-landing-actor/2"
"""The format of the joint actor's sidecar."""
CONTEXT_FORMAT = "marops-landing-actor/3"
"""The format of the joint actor that reads the situation (features 12–17)."""
RULES_FORMAT = "marops-landing-actor/4"
"""The format of the joint actor that reads the situation and the flow rule (12–20)."""


class FeatureSet(NamedTuple):
    """What ``marops train --features NAME`` trains."""

    format: str
    """The sidecar's format."""
    names: tuple[str, ...]
    """The names of the weights, in order."""
    start: np.ndarray
    """Where training starts without ``--init``."""


FEATURE_SETS = {
    "basic": FeatureSet(LANDING_FORMAT, (*FEATURES, *FREE_FEATURES), JOINT_START),
    "context": FeatureSet(
        CONTEXT_FORMAT, (*FEATURES, *CONTEXT_FEATURES, *FREE_FEATURES), CONTEXT_START
    ),
    "rules": FeatureSet(
        RULES_FORMAT,
        (*FEATURES, *CONTEXT_FEATURES, *RULE_FEATURES, *FREE_FEATURES),
        RULES_START,
    ),
}
"""The feature sets a landing actor trains with, by the name ``--features`` gives."""
_FORMATS = {
    LANDING_FORMAT: JOINT_START.size,
    CONTEXT_FORMAT: CONTEXT_START.size,
    RULES_FORMAT: RULES_START.size,
    "marops-landing-actor/1": N_FEATURES,
}
"""The sidecar formats a landing actor may have, and their numbers of weights."""
_UNSUITED = -1e9
"""The score of a slot a drone cannot take (an assignment needs finite scores)."""
_UNLIMITED_SPARES = 3.0
"""What feature 7 reads where swaps are unlimited (the paper's batteries): plenty."""


def _lg(x: np.ndarray) -> np.ndarray:
    return np.log1p(np.maximum(x, 0.0))


def extend_weights(weight: np.ndarray, size: int) -> np.ndarray:
    """The weights of a landing actor (12, 16 or 22 of them) as the first of ``size``
    (16, 22 or 25): its destination weights first, its free landing's last (a sequential
    actor's at 0), every new feature at 0, so the larger actor decides as the smaller one
    did."""
    w = np.asarray(weight, dtype=np.float64).reshape(-1)
    sizes = _FORMATS.values()
    if w.size not in sizes or size not in sizes or size == N_FEATURES or w.size > size:
        raise ValueError(f"cannot extend {w.size} landing weights to {size}")
    n_free = len(FREE_FEATURES)
    dest = w if w.size == N_FEATURES else w[:-n_free]
    out = np.zeros(size)
    out[: dest.size] = dest
    if w.size != N_FEATURES:
        out[-n_free:] = w[-n_free:]
    return out


def operating_model(ops: OpsConfig) -> str:
    """The operating model in words, as sidecars record it and errors name it: ``paper``,
    or the options that make it realistic (``stock=home, batteries, busy``)."""
    if ops.paper:
        return "paper"
    parts = [f"stock={ops.stock}"]
    if ops.batteries_per_depot is not None:
        parts.append("batteries")
    if ops.busy:
        parts.append("busy")
    return ", ".join(parts)


def check_trained_for(trained_for: str | None, model: str, actor: str | Path | None) -> None:
    """Refuse to fly the actor file ``actor``, trained for the operating model
    ``trained_for`` (None: a sidecar that names none), in a run under ``model``."""
    if trained_for is not None and model != trained_for:
        raise InputError(
            f"this actor was trained for the operating model {quoted(trained_for)}, the run's "
            f"[ops] is {model!r}: use a config whose [ops] matches, or another {option('policy')}",
            file=actor,
        )


class DepotState:
    """Per-depot inputs of one window's features (the same for every drone)."""

    def __init__(self, view: WindowView, alpha: float = 0.5) -> None:
        dep = view.depots
        n = len(dep)
        self.value = waiting_per_depot(view, 1.0 + view.pending_delay_h)
        self.count = waiting_per_depot(view)
        self.expected = np.zeros(n)
        prof = dep.arrivals
        if prof is not None and prof.shape == (n, view.n_windows):
            self.expected = prof[:, view.t + 1 : view.t + 3].sum(axis=1)
        spares = view.depot_spares.astype(float)
        self.spares = np.where(np.isinf(spares), _UNLIMITED_SPARES, spares)
        self.charging = view.depot_charging.astype(float)
        self.time = view.t / max(1, view.n_windows)
        self.density = view.n_drones / max(1, n)
        self.alpha = alpha
        self.load = float(self.count.sum()) / max(1, view.n_drones)
        self.flow: np.ndarray | None = None
        """``(N,)`` ready drones the flow rule lands at each depot (``/4`` actors only)."""


def landing_features(
    view: WindowView,
    depots: DepotState,
    s: int,
    there: np.ndarray,
    context: bool = False,
    slot: int = 0,
) -> np.ndarray:
    """``(A, 12)`` the features of a drone at depot ``s``'s destinations, with ``there``
    the drones counted at each depot; ``(A, 18)`` with the situation's (``context``), and
    ``(A, 21)`` with the flow rule's too where ``depots.flow`` is set, for landing slot
    ``slot`` of each destination (module docstring)."""
    dep = view.depots
    dests = dep.candidates[s]
    dist = np.hypot(*(dep.xy[dests] - dep.xy[s]).T) / 1000.0
    per_drone = 1.0 + there[dests]
    score = _lg(depots.value[dests] / per_drone)
    stay = (dests == s).astype(np.float64)
    more = []
    if context:
        density, load = np.log1p(depots.density), np.log1p(depots.load)
        strands = (1.0 - stay) * (depots.spares[dests] <= 0)
        more = [density * stay, density * dist, strands, load * stay]
        more += [depots.alpha * dist, depots.alpha * stay]
        if depots.flow is not None:
            fills = (slot < depots.flow[dests]).astype(np.float64)
            more += [fills, density * fills, load * fills]
    return np.stack(
        [
            _lg(depots.value[dests]),
            _lg(there[dests]),
            score,
            _lg(depots.count[dests]),
            dist,
            _lg(depots.expected[dests]),
            _lg(depots.expected[dests] / per_drone),
            _lg(depots.spares[dests]),
            _lg(depots.charging[dests]),
            stay,
            depots.time * score,
            depots.time * dist,
            *more,
        ],
        axis=1,
    )


class LandingActor(EnergyAware):
    """Scores each destination by ``weight · features`` and lands where the empty drone
    can reach: jointly with 16, 22 or 25 weights, one drone after another with 12 (module
    docstring); a drone that cannot fly stays. ``trained_for`` is the operating model it
    was trained for (None: any); :meth:`configure` refuses a run under another."""

    name = "marops"
    scope: Literal["range", "global"] = "range"

    def __init__(
        self,
        weight: np.ndarray,
        *,
        trained_for: str | None = None,
        path: Path | None = None,
    ) -> None:
        super().__init__()
        w = np.asarray(weight, dtype=np.float64).reshape(-1)
        if w.size not in _FORMATS.values():
            sizes = " or ".join(map(str, sorted(_FORMATS.values())))
            raise ValueError(f"expected {sizes} weights, got {w.size}")
        self.weight = w
        self.trained_for = trained_for
        self.path = path
        self.alpha = 0.5
        """The run's α (features 16–17), set by :meth:`configure`."""
        self._flow: FlowPolicy | None = FlowPolicy() if w.size == RULES_START.size else None
        """The flow rule whose plan features 18–20 read (``/4`` actors)."""
        self._kept = FlowPolicy()
        """The flow rule that plans the drones a joint actor keeps at their depots."""

    @property
    def joint(self) -> bool:
        """Whether the drones decide together (16 or 22 weights) or one after another (12)."""
        return self.weight.size != N_FEATURES

    @property
    def context(self) -> bool:
        """Whether the actor reads the situation (features 12–17, 22 or 25 weights)."""
        return self.weight.size in (CONTEXT_START.size, RULES_START.size)

    @property
    def identity(self) -> str | Path:
        return self.path if self.path is not None else self.name

    def configure(self, cfg: PlannerConfig) -> None:
        super().configure(cfg)
        self.alpha = cfg.plan.alpha
        if self._flow is not None:
            self._flow.configure(cfg)
        self._kept.configure(cfg)
        self.check_model(operating_model(cfg.ops))

    def check_model(self, model: str) -> None:
        """Refuse a run under an operating model other than the one it was trained for."""
        check_trained_for(self.trained_for, model, self.path)

    def act(self, view: WindowView) -> np.ndarray:
        if self.joint:
            return self._act_joint(view)
        out = np.zeros(view.n_drones, dtype=np.int64)
        depots = DepotState(view)
        there = np.bincount(view.drone_depot, minlength=len(view.depots)).astype(np.float64)
        for u, s in enumerate(view.drone_depot):
            s = int(s)
            if not view.ready(u):
                continue  # it stays, and counts at its depot
            there[s] -= 1.0
            score = landing_features(view, depots, s, there) @ self.weight
            score[~reachable(view, u, self._drone_model(view, u))] = -np.inf
            out[u] = int(np.argmax(score))  # first maximum: lower action index on ties
            there[int(view.depots.candidates[s, out[u]])] += 1.0
        return out

    def _act_joint(self, view: WindowView) -> np.ndarray:
        """The joint actor's landings: the assignment of the ready drones to landing
        slots and free landings with the largest total score (module docstring)."""
        from scipy.optimize import linear_sum_assignment

        dep = view.depots
        out = np.zeros(view.n_drones, dtype=np.int64)
        ready = [u for u in range(view.n_drones) if view.ready(u)]
        if not ready:
            return out
        depots = DepotState(view, self.alpha)
        if self._flow is not None:
            depots.flow = self._flow_landings(view, ready)
        held = np.ones(view.n_drones, dtype=bool)
        held[ready] = False
        n = len(dep)
        base = np.bincount(view.drone_depot[held], minlength=n).astype(np.float64)[:n]
        homes = [int(view.drone_depot[u]) for u in ready]
        oks = [np.flatnonzero(reachable(view, u, self._drone_model(view, u))) for u in ready]
        # Depot d has one slot per ready drone that can land there: slot j is the
        # (j + 1)-th to land at d; its columns start at first[d], the free landings last.
        slots = np.zeros(n, dtype=np.int64)
        for s, ok in zip(homes, oks, strict=True):
            slots[np.unique(dep.candidates[s, ok])] += 1
        first = np.concatenate([[0], np.cumsum(slots)])
        k = len(ready)
        score = np.full((k, int(first[-1]) + k), _UNSUITED)
        n_dest = self.weight.size - len(FREE_FEATURES)
        w, w_free = self.weight[:n_dest], self.weight[n_dest:]
        n_own = n_dest - (len(RULE_FEATURES) if self._flow is not None else 0)
        rows: dict[tuple[int, int], np.ndarray] = {}  # (depot, slot): its destinations' scores
        free: dict[int, float] = {}
        for i, (s, ok) in enumerate(zip(homes, oks, strict=True)):
            dests = dep.candidates[s]
            room = slots[dests[ok]]  # the slots of each reachable destination
            for j in range(int(room.max())):
                if (s, j) not in rows:
                    f = landing_features(view, depots, s, base + j, self.context, j)
                    rows[s, j] = f @ w
                    if j == 0:
                        extra = w_free @ (1.0, depots.time, f[0, 2], depots.density)
                        # Staying, without the flow rule's features (it never lands free).
                        own = rows[s, j][0] if n_own == n_dest else f[0, :n_own] @ w[:n_own]
                        free[s] = float(own + extra) - 1e-9  # ties go to a slot
                for a in ok[j < room]:  # ties to the lower action index
                    col = int(first[dests[a]]) + j
                    score[i, col] = max(score[i, col], rows[s, j][a] - 1e-9 * a)
            score[i, first[-1] + i] = free[s]
        landing = np.searchsorted(first, np.arange(first[-1]), side="right") - 1
        for i, c in zip(*linear_sum_assignment(score, maximize=True), strict=True):
            if c >= first[-1]:
                out[ready[i]] = FREE
            elif score[i, c] > _UNSUITED / 2:
                out[ready[i]] = int(np.flatnonzero(dep.candidates[homes[i]] == landing[c])[0])
        self._call_drones(view, out, ready, base)
        self._plan_kept(view, out, ready, base)
        return out

    def _plan_kept(
        self, view: WindowView, out: np.ndarray, ready: list[int], held: np.ndarray
    ) -> None:
        """The drones the actor keeps at their depots are the flow rule's to move
        (docs/method.md §6.1): its min-cost flow of those drones to the coming work, the
        other drones counted where they land (``held``: the drones at each depot that
        cannot fly). The actor's moves and free landings stand; ``out`` changes in place."""
        kept = [u for u in ready if out[u] == 0]
        if not kept:
            return
        at = held + _per_depot(_landings(view, out, ready), len(view.depots))
        acts = self._kept.act(view, kept, at)
        out[kept] = acts[kept]

    def _call_drones(
        self, view: WindowView, out: np.ndarray, ready: list[int], held: np.ndarray
    ) -> None:
        """Parcels no drone is coming for call one (docs/method.md §6.1): a depot where
        parcels have waited a window or more, with no drone there and none landing, takes
        the drone with the shortest way to it over the depots' moves among those that
        would land where nothing waits; that drone flies the way's first move. ``out`` is
        changed in place; ``held``: the drones at each depot that cannot fly."""
        dep = view.depots
        n = len(dep)
        cand = dep.candidates
        waiting = waiting_per_depot(view)
        if not waiting.any():
            return
        lands = _landings(view, out, ready)
        there = held + _per_depot(lands, n)
        oldest = np.zeros(n)
        keep = view.pending_servable
        at, delay = view.waiting_at(), view.pending_delay_h
        if keep is not None:
            at, delay = at[keep], delay[keep]
        np.maximum.at(oldest, at, delay)
        value = waiting_per_depot(view, 1.0 + view.pending_delay_h)
        calling = [
            int(d)
            for d in np.argsort(-value, kind="stable")  # the most waiting value first
            if waiting[d] > 0 and there[d] == 0 and oldest[d] >= view.window_h - 1e-9
        ]
        idle = sorted(u for u, d in lands.items() if waiting[d] == 0)
        if not calling or not idle:
            return
        dist, pred = _ways(dep, self._model, sorted({int(view.drone_depot[u]) for u in idle}))
        oks = {u: reachable(view, u, self._drone_model(view, u)) for u in idle}
        for d in calling:
            best: tuple[float, int, int] | None = None  # (way m, drone, action)
            for u in idle:
                s = int(view.drone_depot[u])
                if not np.isfinite(dist[s][d]):
                    continue
                hop = d  # back along the way to its first move (none: the drone is there)
                while hop != s and pred[s][hop] != s:
                    hop = int(pred[s][hop])
                act = np.flatnonzero((cand[s] == hop) & oks[u])
                if act.size and (best is None or dist[s][d] < best[0]):
                    best = (float(dist[s][d]), u, int(act[0]))
            if best is not None:
                _, u, a = best
                out[u] = a
                idle.remove(u)
                if not idle:
                    return

    def _flow_landings(self, view: WindowView, ready: list[int]) -> np.ndarray:
        """``(N,)`` how many of the ``ready`` drones the flow rule lands at each depot."""
        assert self._flow is not None
        return _per_depot(_landings(view, self._flow.act(view), ready), len(view.depots))


def _landings(view: WindowView, actions: np.ndarray, drones: list[int]) -> dict[int, int]:
    """The depot each of ``drones`` lands at by its action (staying: its own, the
    candidates' first), those landing free left out."""
    cand = view.depots.candidates
    return {
        u: int(cand[int(view.drone_depot[u]), actions[u]]) for u in drones if actions[u] != FREE
    }


def _per_depot(lands: dict[int, int], n: int) -> np.ndarray:
    """``(N,)`` how many of the drones of ``lands`` (:func:`_landings`) land at each depot."""
    at = np.fromiter(lands.values(), dtype=np.int64, count=len(lands))
    return np.bincount(at, minlength=n)[:n].astype(np.float64)


def _ways(
    dep: Any, model: Any, sources: list[int]
) -> tuple[dict[int, np.ndarray], dict[int, np.ndarray]]:
    """Shortest ways (metres) from each of ``sources`` to every depot over the depots'
    moves an empty drone of ``model`` can fly (``scipy.sparse.csgraph.dijkstra``), and
    each way's predecessors: ``(dist[s], pred[s])`` per source depot ``s``."""
    from scipy.sparse import coo_array
    from scipy.sparse.csgraph import dijkstra

    n, a = dep.candidates.shape
    src = np.repeat(np.arange(n), a - 1)
    dst = dep.candidates[:, 1:].reshape(-1)
    metres = np.hypot(*(dep.xy[src] - dep.xy[dst]).T)
    fly = np.array([float(model.leg_energy_j(m, 0.0)) <= model.usable_j for m in metres])
    # 1 m more a move: of two ways of the same length the one of fewer moves.
    graph = coo_array((metres[fly] + 1.0, (src[fly], dst[fly])), shape=(n, n)).tocsr()
    dist, pred = dijkstra(graph, indices=sources, return_predecessors=True)
    return dict(zip(sources, dist, strict=True)), dict(zip(sources, pred, strict=True))


def load_landing_actor(path: Path, side: Any, sidecar: Path) -> LandingActor:
    """The landing actor of the weights file ``path`` (``NAME.safetensors``) described by
    ``side`` (read from ``sidecar``): one finite float32 tensor ``weight`` of 16 values
    (format ``/2``), 22 (``/3``), 25 (``/4``) or 12 (``/1``). Nothing of the file runs (a
    safetensors file is a JSON header and raw numbers)."""
    from ..data.filemodel import validated

    if isinstance(side, dict):
        refuse_misspelt_keys(side, ("format", "operating_model"), sidecar)
    read = validated(_sidecar_model(), side, sidecar)
    size = _FORMATS[read.format]
    if path.stat().st_size > (1 << 16):
        raise InputError("larger than a landing actor's weights", file=path)
    f = read_tensors(path, 1 << 16)
    names = f.names()
    if names != {"weight"}:
        raise InputError(
            f"expected one tensor 'weight', got {sorted(names)}", file=path, column="weight"
        )
    if f.dtype("weight") != "F32" or f.shape("weight") != (size,):
        raise InputError(
            f"expected float32 [{size}], got {f.dtype('weight')} {list(f.shape('weight'))}",
            file=path,
            column="weight",
        )
    weight = f.float32("weight").astype(np.float64)
    if not np.isfinite(weight).all():
        raise InputError("NaN or infinite weights", file=path, column="weight")
    check_weight_range(float(np.abs(weight).max()), path, "weight")
    _check_listed_weights(side, sidecar, weight, path)
    return LandingActor(weight, trained_for=read.operating_model, path=path)


def _check_listed_weights(side: Any, sidecar: Path, weight: np.ndarray, path: Path) -> None:
    """Refuse a sidecar whose ``weight`` (the weights ``marops train`` lists, to 6
    decimals) are not those of the weights file ``path``: the sidecar of another actor
    (docs/method.md §6). A sidecar without the key (written by hand) says nothing."""
    listed = side.get("weight") if isinstance(side, dict) else None
    if listed is None:
        return
    try:
        said = np.asarray(listed, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError("expected a list of numbers", file=sidecar, column="weight") from None
    if said.shape != weight.shape or not np.allclose(said, weight, rtol=1e-6, atol=1e-5):
        raise InputError(
            f"not the weights of {path.name} (the sidecar of another actor?)",
            file=sidecar,
            column="weight",
        )


@functools.cache
def _sidecar_model() -> type[Any]:
    """What a landing actor's sidecar must say: its format (:data:`_FORMATS`) and the
    operating model it was trained for; its other keys are kept as written."""
    from pydantic import ConfigDict, Field

    from ..data.filemodel import FileModel

    class LandingSidecar(FileModel):
        model_config = ConfigDict(extra="ignore")
        noun: ClassVar[str] = "landing actor's sidecar"
        shape: ClassVar[str] = "a JSON object"
        format: Literal[tuple(_FORMATS)] = Field(  # type: ignore[valid-type]
            description="format, one of " + ", ".join(map(repr, _FORMATS))
        )
        operating_model: str = Field(
            min_length=1, description="the operating model the actor was trained for"
        )

    return LandingSidecar
