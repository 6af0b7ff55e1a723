"""The multi-agent training environment: one step = one window, one agent per drone.

Each drone observes the window and picks an action (a destination for MAR-OPS,
destination × plan slot for the MAPPO baseline); the window planner flies the
plans; each drone gets the reward of eq. (10). MAR-OPS drones observe version 3
(:class:`~marops_cli.policies.observation.SequentialObserver`: one after another,
each seeing what the drones before claimed, plus the anticipation features of
version 4), the MAPPO baseline version 2 (all at once, as the paper's). An episode
may be flown at its own trade-off α (``reset(alpha=...)``): the selection, the
observation and the reward then all use it.

Reward (eq. (10)), per drone u and window t::

    r_u(t) = −(1 − α) · σ̃(D_u(t) / s_D) − α · σ̃(E_u(t) / s_E)

* ``E_u(t)``: energy of u's flight in window t (kJ); ``energy_scope="team"``
  gives every drone the fleet's mean instead.
* ``D_u(t)``: the delay u answers for, built from the delay the map adds in
  window t: window length × the requests due by t and still undelivered after
  it. Summed over a day this is exactly the delivery delay of docs/method.md §5, so the
  return measures the metric the policy is judged on. Three readings of the
  paper's "requests u observes" (``TrainConfig.reward_scope``):

  - ``observed``: the requests in the union of u's candidate flight ranges (the
    paper's O_u(t), what u's observation describes). It pays a drone for
    leaving busy areas: its neighbourhood gets quieter, the city does not.
  - ``team``: the whole map's delay split evenly (D_u = total / U). Aligned,
    but a drone's own deliveries move its reward by 1/U: training drifts to
    idle drones, whose saved energy is the only signal it can attribute.
  - ``credit`` (default): the even split, less what u's deliveries spared
    beyond the fleet's mean, D_u = total / U − (S_u − mean S). A request left
    undelivered counts until the day's end (docs/method.md §5), so delivering it in
    window t spares S = window length × (T − max(t, t_i)). The shares still sum
    to the map's total, so the fleet's objective is unchanged; each drone now
    sees its own part of it, as it sees its own energy.

* ``σ̃(x) = 2·sigmoid(ln 3 · x) − 1`` is 0 at 0, 0.5 at 1 and odd (a credit
  share below 0 earns a bonus). It is concave for x > 0, so scales at typical
  values would reward uneven days (Jensen) and flatten the late-day backlog
  that separates good policies from bad.
  The defaults sit above the largest per-window values on the basic scenario
  (99 % of D_u within −5..15 h; E_u ≤ 168.75 kJ, the usable battery), where σ̃
  keeps at least three quarters of its slope at 0: s_D = 20 h, s_E = 500 kJ.
  Their ratio is the exchange rate of the return: 1 h of fleet delay counts as
  s_E / s_D = 25 kJ of fleet energy, near the combined cost's own rate (1 % of a
  basic day's delay, ~6.6 h, against 1 % of its energy, ~140 kJ: 21 kJ/h),
  tilted slightly towards delay.
"""

from __future__ import annotations

import math

import numpy as np

from ..config import PlanConfig, PlannerConfig
from ..data.table import DayRequests
from ..energy import EnergyModel
from ..plans.window import WindowPlan
from ..policies.base import SLOT_PLANNER, SlotActions, WindowView
from ..policies.direct import SlotSelector
from ..policies.observation import (
    Chooser,
    ObsVersion,
    choice_mask,
    n_choices,
    obs_dim,
    observe_and_choose,
    to_actions,
)
from ..segment.depots import Depots
from ..sim.fleet import Fleet
from ..sim.state import DayState, default_fleet
from ..sim.step import WindowStep, fly_window
from .config import TrainConfig

_LN3 = math.log(3.0)


def squash(x: np.ndarray, scale: float) -> np.ndarray:
    """σ̃(x / scale) = 2·sigmoid(ln 3 · x / scale) − 1: 0 at 0, 0.5 at ``scale``, → 1."""
    return 2.0 / (1.0 + np.exp(-_LN3 * np.asarray(x, dtype=np.float64) / scale)) - 1.0


def reward(
    delay_h: np.ndarray, energy_kj: np.ndarray, alpha: float, tcfg: TrainConfig
) -> np.ndarray:
    """Eq. (10) with sigmoid-normalised terms, one value per drone."""
    return -(1.0 - alpha) * squash(delay_h, tcfg.delay_scale_h) - alpha * squash(
        energy_kj, tcfg.energy_scale_kj
    )


def trained_step(cfg: PlannerConfig, tcfg: TrainConfig) -> WindowStep:
    """How training flies a window: as replay flies the actor it exports, a flight-range
    policy; the MAPPO baseline's plan slots rank the paper's subset plans, flown by its
    slot selector (:func:`~.rollout.actor_policy`)."""
    if tcfg.method != "mappo":
        return WindowStep.make(cfg)
    return WindowStep.make(cfg, planner=SLOT_PLANNER, selector=SlotSelector(tcfg.plan_slots))


class DeliveryEnv:
    """A day of the simulator as a multi-agent episode (paper Alg. 3, inner loop).

    ``how`` flies every window (:func:`~marops_cli.sim.step.fly_window`, as replay does);
    by default as the trained policy will be flown (:func:`trained_step`).
    """

    def __init__(
        self,
        depots: Depots,
        cfg: PlannerConfig,
        tcfg: TrainConfig,
        n_drones: int | None = None,
        how: WindowStep | None = None,
    ) -> None:
        self.depots = depots
        self.cfg = cfg
        self.tcfg = tcfg
        self.n_drones = n_drones or cfg.sim.drones
        self.n_dest = int(depots.candidates.shape[1])
        self.base_how = how or trained_step(cfg, tcfg)
        slots = self.base_how.selector
        self.direct = isinstance(slots, SlotSelector)
        if self.direct != (tcfg.method == "mappo"):
            raise ValueError("the MAPPO baseline, and only it, flies its plan slots")
        self.n_slots = slots.n_slots if isinstance(slots, SlotSelector) else 1
        self.how = self.base_how
        self.alpha = self.how.plan.alpha
        self.obs_version = ObsVersion.MAPPO if self.direct else ObsVersion(tcfg.obs_version)
        self.state: DayState | None = None
        self.view: WindowView | None = None
        self.last_plan: WindowPlan | None = None
        """The plan of the window flown last (None before the day's first)."""
        self.t = 0

    @property
    def model(self) -> EnergyModel:
        """The energy model that prices λ (and the drones of a one-type fleet)."""
        return self.how.model

    @property
    def plan_cfg(self) -> PlanConfig:
        """The plan settings of this episode (at its α)."""
        return self.how.plan

    @property
    def n_logits(self) -> int:
        return n_choices(self.n_dest, self.obs_version) * self.n_slots

    @property
    def obs_dim(self) -> int:
        return obs_dim(self.n_dest, self.obs_version)

    def reset(
        self,
        day: DayRequests,
        fleet: Fleet | np.ndarray | None = None,
        alpha: float | None = None,
    ) -> None:
        """Start ``day`` with drones at ``fleet`` (depots, or a fleet with each drone's
        type; default: the busiest depots), at trade-off ``alpha`` (default: the step's)."""
        self.alpha = self.base_how.plan.alpha if alpha is None else float(alpha)
        self.how = self.base_how.at_alpha(self.alpha)
        if fleet is None:
            depot, models = default_fleet(self.depots, self.n_drones), None
        elif isinstance(fleet, Fleet):
            depot, models = fleet.depot, fleet.models()
        else:
            depot, models = np.asarray(fleet), None
        if len(depot) != self.n_drones:
            raise ValueError(f"a fleet of {len(depot)} drones for {self.n_drones} agents")
        plan = self.cfg.plan
        self.state = DayState(
            day, self.depots, depot, plan.coverage, plan.ties, models, model=self.how.model
        )
        self.t = 0
        self.view = self.state.view(0)
        self.last_plan = None

    def observe(self, choose: Chooser) -> tuple[np.ndarray, np.ndarray]:
        """``(obs (U, D), actions (U,))`` of the current window, ``choose`` deciding
        (:func:`~marops_cli.policies.observation.observe_and_choose`)."""
        assert self.view is not None and not self.done
        return observe_and_choose(
            self.view, choose, self.obs_version, model=self.model, plan=self.plan_cfg
        )

    @property
    def done(self) -> bool:
        return self.state is None or self.t >= self.state.day.n_windows

    def action_mask(self) -> np.ndarray:
        """``(U, n_logits)``: every slot of an existing destination (and the free landing)."""
        assert self.view is not None
        return np.repeat(choice_mask(self.view, self.obs_version), self.n_slots, axis=1)

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Fly window t with ``actions``; returns (rewards ``(U,)``, info: each drone's
        ``energy_kj`` and ``delay_h`` (D_u), and ``late_h``, the delay the whole map
        added in this window). :attr:`done` says when the day is over."""
        assert self.state is not None and self.view is not None and not self.done
        st, view = self.state, self.view
        actions = np.asarray(actions, dtype=np.int64)
        dest = to_actions(actions // self.n_slots, self.n_dest)
        chosen = SlotActions(dest, actions % self.n_slots) if self.direct else dest
        starts = view.drone_depot.copy()
        plan = self.last_plan = fly_window(st, self.t, chosen, self.how, view)
        energy_kj = np.array([r.energy_j for r in plan.routes]) / 1000.0
        delay_h, late_h = self._delay_added(starts, self._spared_h(plan.routes))
        e_u = (
            energy_kj
            if self.tcfg.energy_scope == "own"
            else np.full_like(energy_kj, energy_kj.mean())
        )
        r = reward(delay_h, e_u, self.alpha, self.tcfg)
        self.t += 1
        if not self.done:
            self.view = st.view(self.t)
        return r, {"energy_kj": energy_kj, "delay_h": delay_h, "late_h": np.array(late_h)}

    def _spared_h(self, routes: list) -> np.ndarray:
        """Delay each drone's deliveries spared: a request left undelivered would count
        until the day's end (docs/method.md §5), so delivering it in window t spares
        window length × (T − max(t, t_i))."""
        st = self.state
        assert st is not None
        n_w, wh = st.day.n_windows, st.day.window_hours
        return np.array(
            [wh * (n_w - np.maximum(self.t, st.day.due_w[list(r.stops)])).sum() for r in routes],
            dtype=np.float64,
        )

    def _delay_added(self, starts: np.ndarray, spared: np.ndarray) -> tuple[np.ndarray, float]:
        """(D_u(t) per drone, the whole map's added delay): window length × requests
        due by t and still undelivered after window t."""
        st = self.state
        assert st is not None
        late = (st.day.due_w <= self.t) & (st.delivered_w < 0)
        wh = st.day.window_hours
        total = wh * float(late.sum())
        if self.tcfg.reward_scope == "team":
            return np.full(self.n_drones, total / self.n_drones), total
        if self.tcfg.reward_scope == "credit":
            # The fleet's delay, split by credit: the mean share, less what u's deliveries
            # spared beyond the fleet's mean (so the shares still sum to the total).
            return total / self.n_drones - (spared - spared.mean()), total
        per_area = np.bincount(st.area[late], minlength=len(self.depots)).astype(np.float64)
        seen = st.ranges[starts].any(axis=1)  # (U, N): union of u's candidate ranges
        return st.day.window_hours * (seen * per_area[None, :]).sum(axis=1), total
