"""PySwarms' global-best particle swarm on the updating problem, in the unit cube.

The paper's PSO equations, per particle and dimension (r1, r2 uniform in [0, 1]):
    v <- w v + c1 r1 (p_best - x) + c2 r2 (g_best - x),    x <- x + v
"""

from __future__ import annotations

import logging
import logging.config
from contextlib import contextmanager

import numpy as np

from .harness import seeded_global_rngs, unit_scaled


@contextmanager
def _quiet_pyswarms():
    """PySwarms reconfigures the root logger (a stderr handler and a ./report.log file) every
    time it creates a Reporter: when it is imported and in every optimizer's constructor. Keep
    the host's logging as it is, and PySwarms' own loggers below WARNING silent."""
    configure, logger = logging.config.dictConfig, logging.getLogger("pyswarms")
    level = logger.level
    logging.config.dictConfig = lambda config: None
    logger.setLevel(logging.WARNING)
    try:
        yield
    finally:
        logging.config.dictConfig = configure
        logger.setLevel(level)


with _quiet_pyswarms():
    from pyswarms.single import GlobalBestPSO


class PyswarmsPSO:
    """PySwarms GlobalBestPSO (star topology), one swarm evaluation per batch.

    Works in the unit cube (u = (x - xl) / (xu - xl)), so velocities are fractions of the range.
    Options:
        n_particles (30): swarm size, the batch size.
        w (0.729), c1 (1.49445), c2 (1.49445): inertia, cognitive and social weights; the paper
            gives the equations but not its settings, these are Clerc and Kennedy's
            constriction values.
        velocity_clamp ((-0.5, 0.5)): |v| limit as a fraction of the range; PySwarms also draws
            the initial velocities in it (without one they would all be positive, in [0, 1)).
        bh_strategy ("nearest"): PySwarms' handling of particles leaving the bounds; "nearest"
            puts them on the bound (the paper's optimum has most moduli there).
    PySwarms draws from numpy's global generator: it is seeded from `rng` for the run and
    restored afterwards.
    """

    name = "pyswarms-pso"
    #: capabilities (adapters.capabilities)
    anytime = True
    uses_gradients = False
    batch = True
    supports_x0 = True
    #: the distribution it wraps (its version is listed by `femu optimizers`)
    library = 'pyswarms'

    def min_budget(self, n_var: int, n_particles: int = 30, **options) -> int:
        """One swarm evaluation: `n_particles` evaluations."""
        return int(n_particles)

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, x0=None, n_particles: int = 30,
                 w: float = 0.729, c1: float = 1.49445, c2: float = 1.49445,
                 velocity_clamp: tuple[float, float] | None = (-0.5, 0.5), bh_strategy: str = "nearest"):
        f, _ = unit_scaled(objective, bounds)
        n_var = len(bounds[0])
        # enough iterations to spend the budget (ftol is off): the harness ends the run
        iters = -(-int(budget) // int(n_particles))
        xl, xu = (np.asarray(b, dtype=float) for b in bounds)
        with seeded_global_rngs(rng), _quiet_pyswarms():
            init = None
            if x0 is not None:  # the first particle at x0, the others uniform (PySwarms' own draw)
                init = np.random.uniform(0.0, 1.0, (int(n_particles), n_var))
                init[0] = np.clip((np.asarray(x0, dtype=float) - xl) / (xu - xl), 0.0, 1.0)
            pso = GlobalBestPSO(int(n_particles), n_var, {"w": w, "c1": c1, "c2": c2}, init_pos=init,
                                bounds=(np.zeros(n_var), np.ones(n_var)), bh_strategy=bh_strategy,
                                velocity_clamp=None if velocity_clamp is None else tuple(velocity_clamp))
            pso.optimize(f, iters, verbose=False)
