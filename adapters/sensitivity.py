"""sensitivity: the classical inverse eigensensitivity method, as a bounded least-squares fit.

What it minimises: the weighted frequency residuals of the problem,
r_i(theta) = sqrt(w_i) (f_i_meas - f_i(theta)) / f_i_meas, i.e. the frequency part of J
(sum r_i^2). It linearises r with the analytic eigenvalue sensitivities of the FE model
(d lambda = phi^T (dK - lambda dM) phi) and takes bounded trust-region Gauss-Newton steps
(scipy.optimize.least_squares, method 'trf', in parameters scaled to the unit cube so that
moduli of order 1e10 Pa are well conditioned). On a problem whose objective also holds a
shape term (1 - MAC), such as the ``synthetic`` variant, that term is not fitted: the method
follows the frequencies only, while the harness records the full J at every point it visits.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from .harness import unit_scaled


class Sensitivity:
    """Inverse eigensensitivity updating: trust-region least squares on frequency residuals.

    Each point costs one charge of the objective's `least_squares` (an eigen-solve with
    vectors: residuals and Jacobian together); scipy asks for the residuals and then the
    Jacobian at the same accepted point, and the second request is served from a cache.

    The first start is the problem's initial point x0 (the centre of the bounds if the
    objective does not know it). When a fit converges before the budget is spent the method
    starts again from a point drawn uniformly from rng (restarts=True, the default: the
    problem is under-determined, so different starts end on different points of the set of
    near-solutions, and the benchmark compares methods at equal budgets); with restarts=False
    it stops after the first fit and the run's status is ``stopped``. ftol, xtol, gtol are
    scipy's convergence tolerances.
    """

    name = "sensitivity"

    def min_budget(self, n_var: int, **options) -> int:
        """Two evaluations: a start point and one least-squares step."""
        return 2

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, restarts: bool = True,
                 ftol: float = 1e-10, xtol: float = 1e-10, gtol: float = 1e-10):
        """Least-squares fits from x0, then from rng-drawn starts, until the budget is spent
        (or after the first fit when restarts=False)."""
        if not hasattr(objective, "least_squares"):
            raise TypeError("sensitivity needs an objective with least_squares(x) -> (f, residuals, jacobian), "
                            "such as the harness's BudgetedObjective")
        xl, xu = (np.asarray(v, dtype=float) for v in bounds)
        span = xu - xl
        _, to_x = unit_scaled(objective, bounds)
        last = {}

        def at(u):
            key = u.tobytes()
            if last.get("key") != key:
                last.update(key=key, out=objective.least_squares(to_x(u)[0]))
            return last["out"]

        x0 = getattr(getattr(objective, "problem", None), "x0", None)
        u = np.full(len(xl), 0.5) if x0 is None else np.clip((np.asarray(x0, dtype=float) - xl) / span, 0.0, 1.0)
        while True:  # until the harness raises BudgetExhausted, or once without restarts
            least_squares(lambda v: at(v).residuals, u, jac=lambda v: at(v).jacobian * span, bounds=(0.0, 1.0),
                          method="trf", ftol=ftol, xtol=xtol, gtol=gtol)
            if not restarts:
                return
            u = rng.random(len(xl))
