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

from .budget import jacobian_cost
from .harness import unit_scaled


class Sensitivity:
    """Inverse eigensensitivity updating: trust-region least squares on frequency residuals.

    Costs follow the harness's finite-difference rule (adapters.budget.jacobian_cost): a
    trial point where scipy asks only for the residuals costs 1 evaluation, the Jacobian at
    an accepted point n_var more (n_var + 1 in all per Jacobian). When the budget left cannot
    pay for a Jacobian, the rest is spent on points drawn uniformly (the restart distribution),
    so a run uses its budget exactly.

    The first start is x0 when the harness passes it (study option x0=all), else a point drawn
    uniformly from rng. When a fit converges before the budget is spent the method starts again
    from a point drawn uniformly from rng (restarts=True, the default: the problem is
    under-determined, so different starts end on different points of the set of
    near-solutions, and the benchmark compares methods at equal budgets); with restarts=False
    it stops after the first fit and the run's status is ``stopped``. ftol, xtol, gtol are
    scipy's convergence tolerances.
    """

    name = "sensitivity"
    #: capabilities (adapters.capabilities)
    anytime = True
    uses_gradients = True
    batch = False
    supports_x0 = True
    #: the distribution it wraps (its version is listed by `femu optimizers`)
    library = 'scipy'

    def min_budget(self, n_var: int, **options) -> int:
        """A start point and one Jacobian: n_var + 1 evaluations (budget.jacobian_cost)."""
        return jacobian_cost(n_var)

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, x0=None, restarts: bool = True,
                 ftol: float = 1e-10, xtol: float = 1e-10, gtol: float = 1e-10):
        """Least-squares fits from x0 (or a random point), then from rng-drawn starts, until the
        budget is spent (or after the first fit when restarts=False)."""
        if not hasattr(objective, "least_squares"):
            raise TypeError("sensitivity needs an objective with least_squares(x, jacobian) -> (f, residuals, "
                            "jacobian), such as the harness's BudgetedObjective")
        xl, xu = (np.asarray(v, dtype=float) for v in bounds)
        span = xu - xl
        f, to_x = unit_scaled(objective, bounds)
        last = {}

        def at(u, jac: bool):
            key = u.tobytes()
            if last.get("key") != key or (jac and last["out"].jacobian is None):
                if jac and objective.remaining < objective.jacobian_cost:
                    while True:  # no Jacobian left to buy: spend the rest (BudgetExhausted ends it)
                        f(rng.random((objective.remaining, len(xl))))
                last.update(key=key, out=objective.least_squares(to_x(u)[0], jacobian=jac))
            return last["out"]

        u = rng.random(len(xl)) if x0 is None else np.clip((np.asarray(x0, dtype=float) - xl) / span, 0.0, 1.0)
        while True:  # until the harness raises BudgetExhausted, or once without restarts
            least_squares(lambda v: at(v, False).residuals, u, jac=lambda v: at(v, True).jacobian * span,
                          bounds=(0.0, 1.0), method="trf", ftol=ftol, xtol=xtol, gtol=gtol)
            if not restarts:
                return
            u = rng.random(len(xl))
