"""pymoo's real-coded genetic algorithm on the updating problem, one generation per batch."""

from __future__ import annotations

import numpy as np
from pymoo.algorithms.soo.nonconvex.ga import GA
from pymoo.core.problem import Problem
from pymoo.optimize import minimize

from .budget import ga_population


class _Batched(Problem):
    """The budgeted objective as a pymoo Problem: `_evaluate` sends a whole generation at once."""

    def __init__(self, objective, xl, xu):
        super().__init__(n_var=len(xl), n_obj=1, xl=xl, xu=xu)
        self._objective = objective

    def _evaluate(self, X, out, *args, **kwargs):
        out["F"] = self._objective(X)


class PymooGA:
    """pymoo's GA: random initial population, binary tournament selection, SBX crossover,
    polynomial mutation, duplicate elimination, (mu + lambda) survival.

    pymoo's operators scale themselves to the bounds, so the GA works on the moduli (Pa)
    directly. Options:
        pop_size (None): individuals per generation, also the offspring per generation; each
            generation is one batch of FE evaluations. None: `adapters.budget.ga_population`
            (20 on up to 41 parameters, 48 on 96), whatever the budget, so that the GA is anytime
            (a longer run continues a shorter one); pymoo's own 100 was still improving at 2,000
            evaluations on the paper problem, where 20 does better.
        eliminate_duplicates (True): pymoo's removal of repeated offspring.
    With x0 (study option x0=all) the initial population is x0 and pop_size - 1 points drawn
    uniformly from `rng`; otherwise pymoo's own random sampling. Seeded from `rng` through
    pymoo's own `seed` (pymoo draws from its own Generator).
    """

    name = "pymoo-ga"
    #: capabilities (adapters.capabilities)
    anytime = True
    uses_gradients = False
    batch = True
    supports_x0 = True
    #: the distribution it wraps (its version is listed by `femu optimizers`)
    library = 'pymoo'

    def min_budget(self, n_var: int, pop_size: int | None = None, **options) -> int:
        """One initial population: `pop_size` evaluations (default: `ga_population(n_var)`)."""
        return int(pop_size) if pop_size is not None else ga_population(n_var)

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, x0=None, pop_size: int | None = None,
                 eliminate_duplicates: bool = True):
        """pymoo's minimize for `budget` evaluations (the harness ends it)."""
        xl, xu = (np.asarray(b, dtype=float) for b in bounds)
        pop = ga_population(len(xl)) if pop_size is None else int(pop_size)
        extra = {}
        if x0 is not None:
            start = rng.uniform(xl, xu, size=(pop, len(xl)))
            start[0] = np.clip(np.asarray(x0, dtype=float), xl, xu)
            extra["sampling"] = start
        algorithm = GA(pop_size=pop, eliminate_duplicates=eliminate_duplicates, **extra)
        # pymoo finishes whole generations; with n_eval = budget its own termination can never
        # come first, so the harness always ends the run at exactly `budget` evaluations
        minimize(_Batched(objective, xl, xu), algorithm, ("n_eval", int(budget)),
                 seed=int(rng.integers(2**32)), verbose=False)
