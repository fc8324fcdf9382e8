"""An optimizer for benchmarks/sandbox_breakdown.py: one uniform random point per objective call
until the budget ends it, so that a run is nothing but its round trips and evaluations. It
imports only numpy (an optimizer's worker cannot import fe_problem or femu)."""

from __future__ import annotations

import numpy as np


class OnePointPerCall:
    """Uniform random points in the bounds, one per objective call."""

    name = "one-point-per-call"
    min_budget = 1

    def minimize(self, objective, bounds, budget, rng):
        xl, xu = (np.asarray(b, dtype=float) for b in bounds)
        while True:
            objective(rng.uniform(xl, xu))
