"""The one place for the budget rules: a budget is a whole number of FE evaluations >= 1, a
seed a whole number >= 0, an optimizer needs at least its minimum budget, and a Jacobian costs
what finite differences would (`jacobian_cost`).

Every caller (the harness, `run_study`, `femu reproduce`) checks through these functions, so
the messages are the same everywhere; a command-line caller prefixes the flag (``--budget:``).
"""

from __future__ import annotations

from typing import Any

import numpy as np


def _is_int(v) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, bool)


#: The largest budget a run may have (FE evaluations): days of computing on the H-frame.
MAX_BUDGET = 10**9


def check_budget(budget, flag: str | None = None) -> int:
    """`budget` as an int; ValueError unless it is an integer from 1 to `MAX_BUDGET` (FE
    evaluations). The message starts with `flag` (e.g. ``--budget``) when it came from one."""
    what = f"{flag}: must be" if flag else "budget must be"
    if not _is_int(budget) or budget < 1:
        raise ValueError(f"{what} an integer >= 1 (FE evaluations), got {budget!r}")
    if budget > MAX_BUDGET:
        raise ValueError(f"{what} at most {MAX_BUDGET} FE evaluations, got {budget}")
    return int(budget)


def check_seed(seed) -> int:
    """`seed` as an int; ValueError unless it is an integer >= 0."""
    if not _is_int(seed) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    return int(seed)


def jacobian_cost(n_var: int) -> int:
    """FE evaluations charged for the objective, residuals and Jacobian at one point: n_var + 1,
    what a forward-difference Jacobian costs (the point and one step per parameter). Every
    plugin that asks the harness for derivatives pays this, whether the problem computes them
    by finite differences or analytically (the H-frame's analytic eigenvalue sensitivities cost
    one eigen-solve with vectors: charging that would make derivatives almost free and favour
    the methods that use them over every derivative-free method)."""
    return int(n_var) + 1


def population_for_budget(n_var: int, budget: int) -> int:
    """A GA population for `budget` evaluations on `n_var` parameters: about 100 generations
    (budget // 100), at least 10 and n_var // 2, at most 100 (20 for 2,000 evaluations on up to
    40 parameters, 48 on 96). See docs/suite-adapters.md, "Adapter settings"."""
    return int(min(100, max(10, int(budget) // 100, int(n_var) // 2)))


def ga_population(n_var: int) -> int:
    """The GA population a budget does not change (so the GAs are anytime: a longer run
    continues a shorter one): 20, at least n_var // 2, at most 100 (20 on up to 41 parameters,
    48 on 96). 20 is `population_for_budget` at 2,000 evaluations, measured better than pymoo's
    100 on the paper problem; see docs/suite-adapters.md, "Adapter settings"."""
    return int(min(100, max(20, int(n_var) // 2)))


def min_budget(optimizer, n_var: int, **options: Any) -> int:
    """The fewest FE evaluations `optimizer` (a class or an instance) needs on `n_var`
    parameters with `options`: its ``min_budget(n_var, **options)`` method, or a plain int
    attribute ``min_budget`` (older plugins), or 1 when it says nothing."""
    what = getattr(optimizer, "__name__", type(optimizer).__name__)
    try:  # a plugin's own code: whatever it raises or returns is named, not passed on
        need = getattr(optimizer, "min_budget", 1)
        if callable(need):
            if isinstance(optimizer, type):
                optimizer = optimizer()
            need = optimizer.min_budget(int(n_var), **options)
    except Exception as exc:
        raise ValueError(f"optimizer class {what}: asking its min_budget(n_var={n_var}) raised "
                         f"{type(exc).__name__}: {str(exc)[:200]}") from None
    if not _is_int(need):
        raise ValueError(f"optimizer class {what}: min_budget must be a whole number of evaluations, got {need!r}")
    return max(1, int(need))


def check_min_budget(name: str, optimizer, budget: int, n_var: int, **options: Any) -> None:
    """ValueError if `budget` is below what optimizer `name` needs (see `min_budget`)."""
    check_budget_covers(name, min_budget(optimizer, n_var, **options), budget, n_var, **options)


def check_budget_covers(name: str, need: int, budget: int, n_var: int, **options: Any) -> None:
    """ValueError if `budget` is below `need`, the minimum budget optimizer `name` stated (asked
    in its worker by adapters.sandbox.optimizer_facts, or `min_budget`)."""
    if budget < need:
        how = f" with options {options}" if options else ""
        raise ValueError(f"optimizer {name!r} needs a budget of at least {need} evaluations, got {budget} "
                         f"(on {n_var} parameters{how} the method needs at least {need} evaluations to start)")


#: What every solver of a run is told about the start: ``none`` (nothing: each draws its first
#: points from its seed) or ``all`` (the problem's initial point x0, passed as ``x0=``).
X0_MODES = ("none", "all")


def check_x0_mode(mode, flag: str | None = None) -> str:
    """`mode` if it is one of `X0_MODES`; ValueError (starting with `flag`) otherwise."""
    if mode not in X0_MODES:
        what = f"{flag}: must be" if flag else "x0 must be"
        raise ValueError(f"{what} one of {', '.join(X0_MODES)}, got {mode!r}")
    return mode
