"""scipy's dual annealing (generalised simulated annealing with local search) on the
updating problem, in the unit cube, restarted with a fresh seed whenever it stops."""

from __future__ import annotations

import inspect

import numpy as np
from scipy.optimize import dual_annealing

from .harness import unit_scaled

# scipy >= 1.15 takes the generator as `rng`; older versions call it `seed`
_RNG_KEYWORD = "rng" if "rng" in inspect.signature(dual_annealing).parameters else "seed"


class ScipyDualAnnealing:
    """scipy.optimize.dual_annealing, one point per evaluation.

    Works in the unit cube (u = (x - xl) / (xu - xl)), where the default L-BFGS-B local search
    and its finite-difference steps are well scaled. Options (scipy's names and defaults):
        maxiter (1000): global iterations of one annealing run.
        initial_temp (5230.0), restart_temp_ratio (2e-5), visit (2.62), accept (-5.0): the
            annealing schedule and the visiting / acceptance distributions.
        no_local_search (False): True gives plain generalised simulated annealing.
    A run that ends before the budget (maxiter reached) is restarted from a new random point
    with a new seed drawn from `rng`; scipy overruns maxfun inside a local search, the harness
    cuts it at the budget.
    """

    name = "scipy-sa"

    def min_budget(self, n_var: int, **options) -> int:
        """The initial point and one iteration (2 n_var visits): 25 with 12 parameters."""
        return 1 + 2 * int(n_var)

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, maxiter: int = 1000,
                 initial_temp: float = 5230.0, restart_temp_ratio: float = 2e-5, visit: float = 2.62,
                 accept: float = -5.0, no_local_search: bool = False):
        f, _ = unit_scaled(objective, bounds)
        unit_box = [(0.0, 1.0)] * len(bounds[0])
        while True:
            dual_annealing(lambda u: f(u)[0], unit_box, maxiter=int(maxiter), maxfun=int(budget),
                           initial_temp=initial_temp, restart_temp_ratio=restart_temp_ratio, visit=visit,
                           accept=accept, no_local_search=no_local_search,
                           **{_RNG_KEYWORD: np.random.default_rng(int(rng.integers(2**32)))})
