"""The optimizer plugin protocol: what the registry loads and the harness runs.

An optimizer is a class whose instances have

- ``name``: the registry name (str), e.g. ``"scipy-sa"``;
- ``min_budget(n_var, **options) -> int``: the fewest FE evaluations the method needs to start
  on a problem of `n_var` parameters with these `options` (a plain class attribute ``min_budget
  = 25`` is accepted too, see `adapters.budget.min_budget`);
- ``minimize(objective, bounds, budget, rng, **options)``: minimise ``objective`` (a batch
  (n, n_var) in, n values out) inside ``bounds`` = (xl, xu), arrays (n_var,), with at most
  ``budget`` evaluations drawn with the numpy Generator ``rng``. The harness enforces the
  budget by raising `BudgetExhausted` from ``objective``, so a method may loop until stopped;
  the return value is ignored.

and may declare its capabilities as class attributes (`adapters.capabilities`): ``anytime``
(its first k evaluations do not depend on the budget), ``uses_gradients`` (it calls
``objective.least_squares``), ``batch`` (it evaluates whole populations per call) and
``supports_x0`` (its minimize takes ``x0=``). They are optional, so that older plugins still
satisfy the protocol; an undeclared flag counts as False (``supports_x0``: read from the
signature), so a report claims nothing the plugin has not stated.

`Optimizer` is the typing.Protocol (for type checkers and `isinstance`); `OptimizerBase` is an
optional base class with a constant minimum budget.
"""

from __future__ import annotations

from typing import Any, Callable, Protocol, runtime_checkable

import numpy as np

#: A batched objective: points (n, n_var) -> values (n,).
Objective = Callable[[np.ndarray], np.ndarray]


@runtime_checkable
class Optimizer(Protocol):
    """The interface every optimizer plugin implements (see the module doc)."""

    name: str

    def min_budget(self, n_var: int, **options: Any) -> int:
        """The fewest FE evaluations the method needs on `n_var` parameters with `options`."""
        ...

    def minimize(self, objective: Objective, bounds: tuple[np.ndarray, np.ndarray], budget: int,
                 rng: np.random.Generator, **options: Any) -> None:
        """Minimise `objective` within `bounds` in `budget` evaluations drawn with `rng`."""
        ...


class OptimizerBase:
    """A convenient base: `MIN_BUDGET` evaluations whatever the problem; subclasses set
    `name`, override `minimize` and, when the need depends on n_var or options, `min_budget`."""

    name: str = ""
    #: FE evaluations the method needs to start, independent of the problem.
    MIN_BUDGET: int = 1
    #: Capabilities (adapters.capabilities): say True only for what the method does.
    anytime: bool = False
    uses_gradients: bool = False
    batch: bool = False
    supports_x0: bool = False

    def min_budget(self, n_var: int, **options: Any) -> int:
        """`MIN_BUDGET` evaluations."""
        return int(self.MIN_BUDGET)

    def minimize(self, objective: Objective, bounds, budget: int, rng: np.random.Generator,
                 **options: Any) -> None:  # pragma: no cover - abstract
        """Minimise `objective` (see the module doc); subclasses implement it."""
        raise NotImplementedError(f"{type(self).__name__}.minimize")
