"""pycma's CMA-ES (ask and tell) on the updating problem, in the unit cube, with IPOP restarts."""

from __future__ import annotations

import math

import cma
import numpy as np

from .harness import seeded_global_rngs, unit_scaled


class CMAES:
    """CMA-ES from pycma, one population per batch, restarted with a larger population
    (IPOP) from a new random point whenever pycma's stopping criteria fire.

    Works in the unit cube (u = (x - xl) / (xu - xl)) with pycma's BoundTransform for the
    bounds, so one step size fits all twelve moduli. Options:
        sigma0 (0.3): initial step size as a fraction of the range.
        popsize (None): population of the first run; None is pycma's 4 + 3 ln(n_var)
            (11 for 12 parameters).
        incpopsize (2): factor on the population at each restart.
        cma_options (None): further pycma options (see cma.CMAOptions()), e.g.
            {"tolfun": 1e-12} or {"maxiter": 50} to end each run (and restart) sooner.
    pycma samples from numpy's global generator: each run seeds it (from `rng`) and the
    previous state is restored afterwards.
    """

    name = "cma-es"

    def min_budget(self, n_var: int, popsize: int | None = None, **options) -> int:
        """One generation: `popsize`, by default CMA-ES's 4 + floor(3 ln n_var) (11 with 12
        parameters)."""
        return int(popsize) if popsize is not None else 4 + int(3 * math.log(int(n_var)))

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, sigma0: float = 0.3,
                 popsize: int | None = None, incpopsize: float = 2, cma_options: dict | None = None):
        f, _ = unit_scaled(objective, bounds)
        n_var = len(bounds[0])
        opts = {**(cma_options or {}), "bounds": [0.0, 1.0], "verbose": -9, "verb_log": 0, "verb_disp": 0}
        if popsize is not None:
            opts["popsize"] = int(popsize)
        with seeded_global_rngs(rng):
            while True:
                # pycma takes seed 0 for "from the clock": draw from 1 up
                es = cma.CMAEvolutionStrategy(rng.uniform(0.0, 1.0, n_var), sigma0,
                                              dict(opts, seed=int(rng.integers(1, 2**31))))
                while not es.stop():
                    U = es.ask()
                    es.tell(U, f(np.asarray(U)).tolist())
                opts["popsize"] = int(round(es.popsize * incpopsize))
