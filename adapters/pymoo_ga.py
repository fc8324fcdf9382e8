"""pymoo's real-coded genetic algorithm on the updating problem, one generation per batch."""

from __future__ import annotations

import numpy as np
from pymoo.algorithms.soo.nonconvex.ga import GA
from pymoo.core.problem import Problem
from pymoo.optimize import minimize


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
        pop_size (100): individuals per generation, also the offspring per generation; each
            generation is one batch of FE evaluations.
        eliminate_duplicates (True): pymoo's removal of repeated offspring.
    Seeded from `rng` through pymoo's own `seed` (pymoo draws from its own Generator).
    """

    name = "pymoo-ga"

    def min_budget(self, n_var: int, pop_size: int = 100, **options) -> int:
        """One initial population: `pop_size` evaluations."""
        return int(pop_size)

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, pop_size: int = 100,
                 eliminate_duplicates: bool = True):
        algorithm = GA(pop_size=int(pop_size), eliminate_duplicates=eliminate_duplicates)
        # pymoo finishes whole generations; with n_eval = budget its own termination can never
        # come first, so the harness always ends the run at exactly `budget` evaluations
        minimize(_Batched(objective, *bounds), algorithm, ("n_eval", int(budget)),
                 seed=int(rng.integers(2**32)), verbose=False)
