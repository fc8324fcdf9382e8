"""example-de: scipy.optimize.differential_evolution as a femu-bench optimizer plugin.

The whole plugin is the class below: a name, what it can do, the fewest evaluations it needs,
and `minimize`, which drives the library through the objective it is given. The harness owns
the budget: it raises `BudgetExhausted` from the objective when the budget is spent, so the
method may simply run until it is stopped.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import differential_evolution

from adapters.harness import unit_scaled


class ExampleDE:
    """scipy's differential evolution (best1bin), one generation per batch of FE evaluations.

    Works in the unit cube (`adapters.harness.unit_scaled`), where mutation and the tolerance
    are scale-free. Options: popsize (15: individuals per parameter, scipy's default),
    mutation (0.5, 1.0: dithered), recombination (0.7), strategy ("best1bin"). scipy stops a
    run when the population has converged; a new run from a new seed then starts, until the
    harness stops the run. x0 (femu study --x0 all) is a member of the first population.
    """

    name = "example-de"
    # capabilities (adapters.capabilities): nothing here depends on the budget, so a longer
    # run continues a shorter one; every generation is one batch
    anytime = True
    uses_gradients = False
    batch = True
    supports_x0 = True

    def min_budget(self, n_var: int, popsize: int = 15, **options) -> int:
        """One initial population: popsize * n_var evaluations."""
        return int(popsize) * int(n_var)

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, x0=None, popsize: int = 15,
                 mutation=(0.5, 1.0), recombination: float = 0.7, strategy: str = "best1bin"):
        """Differential evolution runs until the harness stops the run."""
        f, _ = unit_scaled(objective, bounds)
        xl, xu = (np.asarray(b, dtype=float) for b in bounds)
        start = None if x0 is None else np.clip((np.asarray(x0, dtype=float) - xl) / (xu - xl), 0.0, 1.0)
        while True:
            # vectorized: scipy passes the whole population as columns (n_var, S), one batch
            differential_evolution(lambda U: f(np.asarray(U).T), [(0.0, 1.0)] * len(xl), strategy=strategy,
                                   maxiter=10**9, popsize=int(popsize), mutation=tuple(mutation)
                                   if isinstance(mutation, list) else mutation, recombination=recombination,
                                   polish=False, vectorized=True, updating="deferred", x0=start,
                                   rng=np.random.default_rng(int(rng.integers(2**32))))
            start = None
