"""femu-bench adapters: optimizers under identical budgets, studies, reports and the CLI."""

from fe_problem import _threads  # noqa: F401  (one BLAS thread: before numpy loads)
from .harness import BudgetedObjective, BudgetExhausted, RunResult, run
from .registry import available, get

__all__ = ["BudgetExhausted", "BudgetedObjective", "RunResult", "available", "get", "run"]
