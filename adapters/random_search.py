"""Uniform random search: the baseline every comparison needs."""

from __future__ import annotations

import numpy as np


class RandomSearch:
    """Uniform samples inside the bounds, in batches of `batch_size` (100), until the harness
    stops the run; x0 first when the study gives it (x0=all)."""

    name = "random-search"
    #: capabilities (adapters.capabilities)
    anytime = True
    uses_gradients = False
    batch = True
    supports_x0 = True
    #: the distribution it wraps (its version is listed by `femu optimizers`)
    library = None

    def min_budget(self, n_var: int, **options) -> int:
        """One evaluation."""
        return 1

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, x0=None, batch_size: int = 100):
        """Batches of uniform points until stopped."""
        xl, xu = bounds
        if x0 is not None:
            objective(np.atleast_2d(np.asarray(x0, dtype=float)))
        while True:
            objective(rng.uniform(xl, xu, size=(batch_size, len(xl))))
