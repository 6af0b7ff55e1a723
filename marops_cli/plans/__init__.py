"""Candidate plans, their visiting order and the selection program (docs/method.md §4)."""

from .order import MAX_STOPS, SubsetOrders, best_order, subset_orders
from .plans import NoFeasiblePlanError, PlanSet, SelectionProblem, build_plans
from .select import (
    GreedySelector,
    MilpSelector,
    SelectionResult,
    Selector,
    greedy_select,
    make_selector,
    solve_highs_direct,
)

__all__ = [
    "MAX_STOPS",
    "GreedySelector",
    "MilpSelector",
    "NoFeasiblePlanError",
    "PlanSet",
    "SelectionProblem",
    "SelectionResult",
    "Selector",
    "SubsetOrders",
    "best_order",
    "build_plans",
    "greedy_select",
    "make_selector",
    "solve_highs_direct",
    "subset_orders",
]
