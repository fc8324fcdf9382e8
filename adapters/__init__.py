"""femu-bench adapters: optimizer plugins under identical budgets.

- protocol: the plugin interface (`Optimizer`, `OptimizerBase`);
- registry: the built-ins and the entry-point group ``femu.optimizers`` (`available`, `get`);
- budget: the budget, seed and minimum-budget rules; provenance: library versions of a run;
- harness: the budgeted objective and `run()`, which returns a `RunResult`;
- sandbox (the evaluating side) and sandbox_worker (the optimizer's side): every run's optimizer
  in a worker process that never holds the problem; processes: ending a worker with what it started;
- one module per optimizer (pymoo_ga, deap_ga, pyswarms_pso, scipy_sa, mlp_surrogate,
  random_search, cma_es, sensitivity) and their shared GA operators (ga_operators);
- variants: the named problem variants a study runs on.

Nothing here imports the application (femu) or its command-line, plotting, progress or cluster
libraries (tests/test_layout.py checks).
"""

from . import _threads  # noqa: F401  (one BLAS thread: before numpy loads; not via fe_problem, see sandbox_worker)
from .budget import check_budget, check_min_budget, min_budget
from .harness import BudgetedObjective, BudgetExhausted, RunResult, run
from .protocol import Optimizer, OptimizerBase
from .registry import available, get

__all__ = ["BudgetExhausted", "BudgetedObjective", "Optimizer", "OptimizerBase", "RunResult", "available",
           "check_budget", "check_min_budget", "get", "min_budget", "run"]
