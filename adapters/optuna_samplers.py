"""optuna-cmaes and optuna-tpe: optuna's CMA-ES sampler (the `cmaes` library) and its TPE
sampler, one trial per FE evaluation, in the unit cube."""

from __future__ import annotations

import warnings

import numpy as np

from .harness import unit_scaled


def _optimize(sampler, f, n_var: int, budget: int, x0_u) -> None:
    """Trials of a new in-memory study until the harness stops the run: each trial suggests
    u_i in [0, 1] and is one FE evaluation; x0 (in u) is enqueued as the first trial when given.
    optuna re-raises the harness's stop signal from the objective (its default `catch=()`)."""
    import optuna

    names = [f"u{i}" for i in range(n_var)]

    def objective(trial) -> float:
        u = np.array([trial.suggest_float(n, 0.0, 1.0) for n in names])
        return float(f(u)[0])

    verbosity = optuna.logging.get_verbosity()
    # optuna logs every trial at INFO and the harness's stop signal as a failed trial at
    # WARNING (and the new study at INFO): silent during the run, the host's level put back after
    optuna.logging.set_verbosity(optuna.logging.ERROR)
    try:
        study = optuna.create_study(direction="minimize", sampler=sampler)
        if x0_u is not None:
            study.enqueue_trial(dict(zip(names, map(float, x0_u))))
        study.optimize(objective, n_trials=int(budget), gc_after_trial=False, show_progress_bar=False)
    finally:
        optuna.logging.set_verbosity(verbosity)


def _unit(x0, bounds):
    if x0 is None:
        return None
    xl, xu = (np.asarray(b, dtype=float) for b in bounds)
    return np.clip((np.asarray(x0, dtype=float) - xl) / (xu - xl), 0.0, 1.0)


class OptunaCmaEs:
    """optuna's CmaEsSampler (the `cmaes` library's CMA-ES), one trial per evaluation.

    Settings: sigma0 (0.3, a fraction of the unit range, as cma-es), popsize (None: the
    library's 4 + 3 ln n_var). No restarts: optuna 4.4 deprecated the sampler's
    `restart_strategy` (it falls back to none; IPOP moved to OptunaHub), so after convergence
    the run keeps sampling near its optimum; `cma-es` is the restarted CMA-ES. The mean starts
    at x0 when the study gives it (x0=all), else at a point drawn from `rng`; the sampler is
    seeded from `rng`.
    """

    name = "optuna-cmaes"
    #: capabilities (adapters.capabilities)
    anytime = True
    uses_gradients = False
    batch = False
    supports_x0 = True
    library = "optuna"

    def min_budget(self, n_var: int, **options) -> int:
        """One trial."""
        return 1

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, x0=None, sigma0: float = 0.3,
                 popsize: int | None = None):
        """optuna trials until the harness stops the run."""
        import optuna

        f, _ = unit_scaled(objective, bounds)
        n_var = len(bounds[0])
        start = _unit(x0, bounds)
        mean = rng.uniform(0.0, 1.0, n_var) if start is None else start
        with warnings.catch_warnings():
            # optuna 4.9 deprecated x0 and sigma0 (to be removed in 6; pyproject pins < 6); without x0 the
            # mean starts at the centre of the box, which on the paper problem is the initial
            # model: a solver told nothing (x0=none) must not get it
            warnings.filterwarnings("ignore", message="`(x0|sigma0)` has been deprecated", category=FutureWarning)
            sampler = optuna.samplers.CmaEsSampler(
                x0={f"u{i}": float(v) for i, v in enumerate(mean)}, sigma0=float(sigma0),
                seed=int(rng.integers(2**31)), popsize=popsize)
        _optimize(sampler, f, n_var, budget, None)


class OptunaTPE:
    """optuna's TPESampler (tree-structured Parzen estimator), one trial per evaluation.

    Settings: n_startup_trials (None: max(10, n_var + 1) random trials before the model, so that
    every dimension is sampled), multivariate (True: a joint density over the parameters, which
    optuna recommends for correlated ones such as moduli). The first trial is x0 when the study
    gives it (x0=all); the sampler is seeded from `rng`. TPE's cost per trial grows with the
    trials already made: budgets of thousands take minutes of optimizer time (the record's
    opt_cpu_s shows it).
    """

    name = "optuna-tpe"
    #: capabilities (adapters.capabilities)
    anytime = True
    uses_gradients = False
    batch = False
    supports_x0 = True
    library = "optuna"

    def min_budget(self, n_var: int, **options) -> int:
        """One trial."""
        return 1

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, x0=None,
                 n_startup_trials: int | None = None, multivariate: bool = True):
        """optuna trials until the harness stops the run."""
        import optuna

        f, _ = unit_scaled(objective, bounds)
        n_var = len(bounds[0])
        startup = max(10, n_var + 1) if n_startup_trials is None else int(n_startup_trials)
        sampler = optuna.samplers.TPESampler(n_startup_trials=startup, multivariate=multivariate,
                                             seed=int(rng.integers(2**31)))
        _optimize(sampler, f, n_var, budget, _unit(x0, bounds))
