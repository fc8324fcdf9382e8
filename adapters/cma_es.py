"""pycma's CMA-ES with restarts (IPOP or BIPOP) through `cma.fmin2`, in the unit cube."""

from __future__ import annotations

import math

import cma
import numpy as np

from .harness import seeded_global_rngs, unit_scaled


class CMAES:
    """CMA-ES from pycma, run by ``cma.fmin2`` with restarts: IPOP (each restart doubles the
    population, from a new random point) or, with bipop=True, BIPOP (large-population runs
    interleaved with small local ones). One population is one batch of FE evaluations
    (``parallel_objective``).

    Works in the unit cube (u = (x - xl) / (xu - xl)) with pycma's BoundTransform for the
    bounds, so one step size fits every parameter whatever their units. Settings, for any
    n_var (2 to 200) and budget:
        sigma0 (0.3): initial step size as a fraction of the range (pycma advises about a
            quarter of the domain).
        popsize (None): population of the first run; None is pycma's 4 + 3 ln(n_var)
            (11 with 12 parameters, 17 with 96).
        incpopsize (2): factor on the population at each IPOP restart.
        bipop (False): BIPOP instead of IPOP (measured on the paper problem at 2,000
            evaluations: no better).
        restarts (1000): the most restarts; enough that the harness's budget always ends the run.
        cma_options (None): further pycma options (see cma.CMAOptions()), e.g.
            {"tolfun": 1e-12}.
    The first run starts at x0 when the study gives it (x0=all), else at a point drawn from
    `rng`; every restart starts at a point drawn uniformly from `rng`. pycma samples from numpy's
    global generator: each run seeds it (from `rng`) and restores the previous state after.
    """

    name = "cma-es"
    #: capabilities (adapters.capabilities)
    anytime = True
    uses_gradients = False
    batch = True
    supports_x0 = True
    #: the distribution it wraps (its version is listed by `femu optimizers`)
    library = 'cma'

    def min_budget(self, n_var: int, popsize: int | None = None, **options) -> int:
        """One generation: `popsize`, by default CMA-ES's 4 + floor(3 ln n_var) (11 with 12
        parameters)."""
        return int(popsize) if popsize is not None else 4 + int(3 * math.log(int(n_var)))

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, x0=None, sigma0: float = 0.3,
                 popsize: int | None = None, incpopsize: float = 2, bipop: bool = False, restarts: int = 1000,
                 cma_options: dict | None = None):
        """fmin2 with restarts until the harness stops the run."""
        f, _ = unit_scaled(objective, bounds)
        xl, xu = (np.asarray(b, dtype=float) for b in bounds)
        starts = [] if x0 is None else [np.clip((np.asarray(x0, dtype=float) - xl) / (xu - xl), 0.0, 1.0)]

        def start() -> np.ndarray:  # fmin2 calls it at every (re)start
            return starts.pop() if starts else rng.uniform(0.0, 1.0, len(xl))

        opts = {**(cma_options or {}), "bounds": [0.0, 1.0], "verbose": -9, "verb_log": 0, "verb_disp": 0}
        if popsize is not None:
            opts["popsize"] = int(popsize)
        with seeded_global_rngs(rng):
            # pycma takes seed 0 for "from the clock": draw from 1 up
            opts["seed"] = int(rng.integers(1, 2**31))
            cma.fmin2(None, start, sigma0, opts, restarts=int(restarts), incpopsize=incpopsize, bipop=bool(bipop),
                      parallel_objective=lambda U: f(np.asarray(U)).tolist())
