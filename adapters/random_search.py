"""Uniform random search: the baseline every comparison needs."""

from __future__ import annotations

import numpy as np


class RandomSearch:
    """Uniform samples inside the bounds, in batches, until the harness stops the run."""

    name = "random-search"

    def min_budget(self, n_var: int, **options) -> int:
        """One evaluation."""
        return 1

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, batch_size: int = 100):
        xl, xu = bounds
        while True:
            objective(rng.uniform(xl, xu, size=(batch_size, len(xl))))
