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

The public names load on first use (PEP 562 `__getattr__`): `femu study --help` lists the
registry without numpy (issue 25).
"""

import importlib

from . import _threads  # noqa: F401  (one BLAS thread: before numpy loads; not via fe_problem, see sandbox_worker)

#: public name -> the submodule that defines it
_WHERE = {
    **dict.fromkeys(("check_budget", "check_min_budget", "min_budget"), "budget"),
    **dict.fromkeys(("BudgetedObjective", "BudgetExhausted", "RunResult", "run"), "harness"),
    **dict.fromkeys(("Optimizer", "OptimizerBase"), "protocol"),
    **dict.fromkeys(("available", "get"), "registry"),
}

__all__ = ["BudgetExhausted", "BudgetedObjective", "Optimizer", "OptimizerBase", "RunResult", "available",
           "check_budget", "check_min_budget", "get", "min_budget", "run"]


def __getattr__(name: str):
    """A public name (imported from its submodule on first use), or a submodule."""
    where = _WHERE.get(name)
    if where is not None:
        value = getattr(importlib.import_module(f".{where}", __name__), name)
        globals()[name] = value
        return value
    try:
        return importlib.import_module(f".{name}", __name__)
    except ModuleNotFoundError as exc:
        if exc.name != f"{__name__}.{name}":
            raise
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None


def __dir__():
    return sorted(set(globals()) | set(_WHERE))
