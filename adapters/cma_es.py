"""pycma's CMA-ES with IPOP restarts, in the unit cube, bounds kept by resampling (or BIPOP
through `cma.fmin2`)."""

from __future__ import annotations

import math

import cma
import numpy as np

from .harness import seeded_global_rngs, unit_scaled


class CMAES:
    """CMA-ES from pycma (`cma.CMAEvolutionStrategy`, ask and tell) with IPOP restarts: each
    restart doubles the population and starts from a new random point, when pycma's own
    termination criteria end a run. One population is one batch of FE evaluations.

    Works in the unit cube (u = (x - xl) / (xu - xl)), so one step size fits every parameter
    whatever their units. The bounds are kept as the `cmaes` library (optuna's CmaEsSampler)
    keeps them: a candidate outside the cube is drawn again from the same distribution (up to
    100 times), then clipped. pycma's own BoundTransform (the earlier setting, still used with
    bipop=True) maps the search space through a quadratic within 0.05 of each bound, which
    distorts the landscape where the optimum of an updating problem often lies (3 of the 12
    moduli of hframe-freq/12/1 are above 0.93 of their range): it made this adapter 6-9x worse
    than `cmaes` at 1,000 evaluations there; with resampling it is as good or better
    (docs/suite-adapters.md, "Adapters against their libraries"). Settings, for any n_var and budget:
        sigma0 (0.3): initial step size as a fraction of the range (pycma advises about a
            quarter of the domain).
        popsize (None): population of the first run; None is pycma's 4 + 3 ln(n_var)
            (11 with 12 parameters, 17 with 96).
        incpopsize (2): factor on the population at each IPOP restart.
        bipop (False): BIPOP restarts by ``cma.fmin2`` (with pycma's BoundTransform) instead.
        restarts (1000): the most restarts; enough that the harness's budget always ends the run.
        cma_options (None): further pycma options (see cma.CMAOptions()), e.g.
            {"tolfun": 1e-12}.
    The first run starts at x0 when the study gives it (x0=all), else at a point drawn from
    `rng`; every restart starts at a point drawn uniformly from `rng`. pycma samples from numpy's
    global generator: each run seeds it (from `rng`) and restores the previous state after.
    Nothing depends on the budget: anytime.
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
        """IPOP restarts (or fmin2's BIPOP) until the harness stops the run."""
        f, _ = unit_scaled(objective, bounds)
        xl, xu = (np.asarray(b, dtype=float) for b in bounds)
        starts = [] if x0 is None else [np.clip((np.asarray(x0, dtype=float) - xl) / (xu - xl), 0.0, 1.0)]

        def start() -> np.ndarray:  # fmin2 calls it at every (re)start
            return starts.pop() if starts else rng.uniform(0.0, 1.0, len(xl))

        opts = {**(cma_options or {}), "verbose": -9, "verb_log": 0, "verb_disp": 0}
        if popsize is not None:
            opts["popsize"] = int(popsize)
        with seeded_global_rngs(rng):
            # pycma takes seed 0 for "from the clock": draw from 1 up
            opts["seed"] = int(rng.integers(1, 2**31))
            if bipop:
                cma.fmin2(None, start, sigma0, {**opts, "bounds": [0.0, 1.0]}, restarts=int(restarts),
                          incpopsize=incpopsize, bipop=True, parallel_objective=lambda U: f(np.asarray(U)).tolist())
                return
            lam = int(opts.get("popsize", 4 + int(3 * math.log(len(xl)))))
            for _ in range(int(restarts) + 1):
                es = cma.CMAEvolutionStrategy(start(), sigma0, {**opts, "popsize": lam})
                while not es.stop():
                    U = _inside(es)
                    es.tell(list(U), f(U).tolist())
                lam = int(round(lam * incpopsize))
                opts["seed"] = int(rng.integers(1, 2**31))


def _inside(es, tries: int = 100) -> np.ndarray:
    """One population from `es` inside the unit cube: rows outside drawn again from the same
    distribution (up to `tries` times, as the `cmaes` library does), the rest clipped."""
    U = np.asarray(es.ask(), dtype=float)
    for _ in range(tries):
        out = np.flatnonzero(np.any((U < 0.0) | (U > 1.0), axis=1))
        if not len(out):
            break
        U[out] = np.asarray(es.ask(len(out)), dtype=float)
    return np.clip(U, 0.0, 1.0)
