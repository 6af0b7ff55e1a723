"""Candidate plans, their visiting order and the selection program (docs/method.md §4)."""

from .order import MAX_STOPS, SubsetOrders, best_order, subset_orders
from .planner import DronePlans, Planner, make_planner
from .plans import Candidates, NoFeasiblePlanError, PlanSet, SelectionProblem, build_plans
from .select import (
    GreedySelector,
    MilpSelector,
    SelectionResult,
    SelectionStatus,
    Selector,
    greedy_select,
    make_selector,
    solve_highs_direct,
)

__all__ = [
    "MAX_STOPS",
    "Candidates",
    "DronePlans",
    "GreedySelector",
    "MilpSelector",
    "NoFeasiblePlanError",
    "Planner",
    "PlanSet",
    "SelectionProblem",
    "SelectionResult",
    "SelectionStatus",
    "Selector",
    "SubsetOrders",
    "best_order",
    "build_plans",
    "greedy_select",
    "make_planner",
    "make_selector",
    "solve_highs_direct",
    "subset_orders",
]
