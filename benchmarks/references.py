"""Each wrapped library's own driver, as a plugin the harness runs at equal evaluations: what an
adapter of femu-bench is compared with (benchmarks/adapter_references.py, docs/suite.md,
tests/test_adapter_references.py). Each uses the library's documented defaults in the unit
cube, draws its start from the run's seed and, where the library stops by itself, starts
again from a new seed until the budget is spent (as the adapters do), so the comparison is at
exactly equal evaluations.

REFERENCES maps a built-in to (its reference's "module:Class", what the reference is).
"""

from __future__ import annotations

import threading

import numpy as np

from adapters.harness import seeded_global_rngs, unit_scaled


class CmaesLibrary:
    """The `cmaes` library's CMA (what optuna's CmaEsSampler runs): ask/tell, sigma0 0.3,
    bounds by its resampling; a new CMA with twice the population when it stops (IPOP)."""

    anytime = True

    def minimize(self, objective, bounds, budget, rng, x0=None):
        from cmaes import CMA

        f, _ = unit_scaled(objective, bounds)
        n = len(bounds[0])
        popsize = None
        while True:
            opt = CMA(mean=rng.uniform(0.0, 1.0, n), sigma=0.3, bounds=np.array([[0.0, 1.0]] * n),
                      seed=int(rng.integers(2**31)), population_size=popsize)
            while not opt.should_stop():
                X = np.array([opt.ask() for _ in range(opt.population_size)])
                opt.tell(list(zip(X, f(X))))
            popsize = 2 * opt.population_size


class PymooDefaultGA:
    """pymoo's GA with its defaults (population 100) through pymoo.optimize.minimize."""

    def minimize(self, objective, bounds, budget, rng, x0=None):
        from pymoo.algorithms.soo.nonconvex.ga import GA
        from pymoo.optimize import minimize

        from adapters.pymoo_ga import _Batched

        xl, xu = (np.asarray(b, dtype=float) for b in bounds)
        minimize(_Batched(objective, xl, xu), GA(), ("n_eval", int(budget)), seed=int(rng.integers(2**32)),
                 verbose=False)


class ScipyDualAnnealingDefaults:
    """scipy.optimize.dual_annealing with its defaults (maxfun = the budget), unit cube."""

    def minimize(self, objective, bounds, budget, rng, x0=None):
        from scipy.optimize import dual_annealing

        f, _ = unit_scaled(objective, bounds)
        n = len(bounds[0])
        while True:
            dual_annealing(lambda u: float(f(u)[0]), [(0.0, 1.0)] * n, maxfun=int(budget),
                           rng=np.random.default_rng(int(rng.integers(2**32))))


class ScipyLeastSquaresFD:
    """scipy.optimize.least_squares ('trf') on the problem's whole residual with scipy's own
    forward-difference Jacobian: every residual vector costs one evaluation (n_var per
    Jacobian); restarts from uniform points."""

    uses_gradients = True

    def minimize(self, objective, bounds, budget, rng, x0=None):
        from scipy.optimize import least_squares

        xl, xu = (np.asarray(b, dtype=float) for b in bounds)
        span = xu - xl

        def residuals(u):
            return objective.least_squares(xl + np.clip(u, 0.0, 1.0) * span, jacobian=False).residuals

        while True:
            least_squares(residuals, rng.random(len(xl)), bounds=(0.0, 1.0), method="trf", jac="2-point",
                          ftol=1e-10, xtol=1e-10, gtol=1e-10)


class PyswarmsDefaults:
    """PySwarms' GlobalBestPSO with the options of its documentation (c1 0.5, c2 0.3, w 0.9),
    30 particles, unit cube."""

    def minimize(self, objective, bounds, budget, rng, x0=None):
        from adapters.pyswarms_pso import GlobalBestPSO, _quiet_pyswarms

        f, _ = unit_scaled(objective, bounds)
        n = len(bounds[0])
        with seeded_global_rngs(rng), _quiet_pyswarms():
            pso = GlobalBestPSO(30, n, {"c1": 0.5, "c2": 0.3, "w": 0.9}, bounds=(np.zeros(n), np.ones(n)))
            pso.optimize(f, -(-int(budget) // 30), verbose=False)


class DeapEaSimple:
    """DEAP's eaSimple as its tutorial sets it: population 100, cxpb 0.5, mutpb 0.2, SBX and
    polynomial mutation (eta 20), tournament 3, unit cube."""

    def minimize(self, objective, bounds, budget, rng, x0=None):
        from adapters.deap_stock import DeapGAStock

        DeapGAStock().minimize(objective, bounds, budget, rng, population=100, cxpb=0.5, mutpb=0.2)


class NevergradNGOptDirect:
    """nevergrad's own ``ng.optimizers.NGOpt(parametrization, budget).minimize`` on the objective
    (unit cube, budget = the run's, nevergrad's default num_workers 1), one point per call.

    With nevergrad 1.0.12 and numpy 2.4 the library's loop does not run as released: the
    adapter's three workarounds of library defects are applied for the run (MetaModel's float()
    of a length-1 array, CmaFmin2's unseeded cma.fmin, recast threads left waiting), and after
    each of minimize's own tells the recast threads are let post their next point (else a seed
    does not fix the run). None of them changes what NGOpt chooses or how it searches."""

    def minimize(self, objective, bounds, budget, rng, x0=None):
        import nevergrad as ng

        from adapters.nevergrad_ngopt import (_global_rngs_kept, _metamodel_scalars, _recast_threads_settled,
                                              _recast_threads_stopped, _seeded_cma_fmin)

        f, _ = unit_scaled(objective, bounds)
        n = len(bounds[0])
        param = ng.p.Array(init=rng.uniform(0.0, 1.0, n), lower=0.0, upper=1.0)
        param.random_state = np.random.RandomState(int(rng.integers(2**32)))
        with _global_rngs_kept(), seeded_global_rngs(rng), _metamodel_scalars(), _seeded_cma_fmin(), \
                _recast_threads_stopped():
            started = set(threading.enumerate())
            opt = ng.optimizers.NGOpt(parametrization=param, budget=int(budget))
            tell = opt.tell

            def tell_settled(*args, **kwargs):
                tell(*args, **kwargs)
                _recast_threads_settled(started)

            opt.tell = tell_settled
            opt.minimize(lambda u: float(f(u)[0]))


class OptunaTPEDirect:
    """optuna's own driver, ``study.optimize``, with TPESampler at the adapter's settings
    (multivariate, n_startup_trials max(10, n_var + 1)), written as optuna's documentation
    writes it: a plain objective of one trial per evaluation in the unit cube. The sampler's
    seed is drawn from the run's generator as the adapter draws it, so with one seed the two
    make the same runs unless the adapter changes what TPE sees (seed noise of TPE, 3x
    between the medians of 3 seeds at 300 evaluations, would hide such a change in a ratio)."""

    def minimize(self, objective, bounds, budget, rng, x0=None):
        import optuna

        f, _ = unit_scaled(objective, bounds)
        n = len(bounds[0])
        optuna.logging.set_verbosity(optuna.logging.ERROR)
        sampler = optuna.samplers.TPESampler(n_startup_trials=max(10, n + 1), multivariate=True,
                                             seed=int(rng.integers(2**31)))
        study = optuna.create_study(direction="minimize", sampler=sampler)
        study.optimize(lambda t: float(f(np.array([t.suggest_float(f"u{i}", 0.0, 1.0) for i in range(n)]))[0]),
                       n_trials=int(budget))


#: built-in -> (its reference, what the reference is)
REFERENCES = {
    "cma-es": ("references:CmaesLibrary", "`cmaes` CMA, ask/tell, IPOP"),
    "optuna-cmaes": ("references:CmaesLibrary", "`cmaes` CMA, ask/tell, IPOP"),
    "pymoo-ga": ("references:PymooDefaultGA", "pymoo GA() defaults (population 100)"),
    "deap-ga-stock": ("references:DeapEaSimple", "DEAP eaSimple, tutorial settings"),
    "pyswarms-pso": ("references:PyswarmsDefaults", "PySwarms GlobalBestPSO, documented options"),
    "scipy-sa": ("references:ScipyDualAnnealingDefaults", "scipy dual_annealing defaults"),
    "sensitivity": ("references:ScipyLeastSquaresFD", "scipy least_squares, 2-point Jacobian"),
    "nevergrad-ngopt": ("references:NevergradNGOptDirect", "nevergrad NGOpt(...).minimize, same seed"),
    "optuna-tpe": ("references:OptunaTPEDirect", "optuna study.optimize, TPESampler, same settings and seed"),
    "mlp-surrogate": ("random-search", "random search (no library: the paper's method)"),
    "deap-ga": ("random-search", "random search (no library: the paper's operators)"),
}
