"""femu-bench adapters: optimizers under identical budgets, studies, reports and the CLI."""

from .harness import BudgetedObjective, BudgetExhausted, RunResult, run
from .registry import available, get

__all__ = ["BudgetExhausted", "BudgetedObjective", "RunResult", "available", "get", "run"]
