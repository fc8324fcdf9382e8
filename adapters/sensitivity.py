"""sensitivity: the classical inverse eigensensitivity method, as a bounded least-squares fit.

What it minimises: the whole objective J as a sum of squares of the problem's residuals
(`UpdatingProblem.least_squares`): the weighted frequency residuals
r_i(theta) = sqrt(w_i) (f_i_meas - f_i(theta)) / f_i_meas and, when J has a shape term, the
shape residuals sqrt(shape_weight) (a - (a.b) b) of each mode (unit measured and model shapes,
squared norm shape_weight (1 - MAC)), with the problem's weights. It linearises r (frequency
rows from the analytic eigenvalue sensitivities d lambda = phi^T (dK - lambda dM) phi, shape
rows by forward differences) and takes bounded trust-region Gauss-Newton steps
(scipy.optimize.least_squares, method 'trf', in parameters scaled to the unit cube so that
moduli of order 1e10 Pa are well conditioned).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from .budget import jacobian_cost
from .harness import unit_scaled


class Sensitivity:
    """Inverse eigensensitivity updating: trust-region least squares on the whole residual.

    Costs follow the harness's finite-difference rule (adapters.budget.jacobian_cost): a
    trial point where scipy asks only for the residuals costs 1 evaluation, the Jacobian at
    an accepted point n_var more (n_var + 1 in all per Jacobian). When the budget left cannot
    pay for a Jacobian, the rest is spent evaluating the current point again, so a run uses its
    budget exactly and is anytime: a longer run would spend those evaluations on the Jacobian at
    that point, which finds nothing better either (uniform draws there, as before, made the
    first evaluations of a short run differ from a long one's).

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
                # a Jacobian at the point whose residuals were just bought costs one less
                cost = objective.jacobian_cost - (last.get("key") == key)
                if jac and objective.remaining < cost:
                    # no Jacobian left to buy: the rest on this point (BudgetExhausted ends it)
                    f(np.repeat(u[None], objective.remaining, axis=0))
                last.update(key=key, out=objective.least_squares(to_x(u)[0], jacobian=jac))
            return last["out"]

        u = rng.random(len(xl)) if x0 is None else np.clip((np.asarray(x0, dtype=float) - xl) / span, 0.0, 1.0)
        while True:  # until the harness raises BudgetExhausted, or once without restarts
            least_squares(lambda v: at(v, False).residuals, u, jac=lambda v: at(v, True).jacobian * span,
                          bounds=(0.0, 1.0), method="trf", ftol=ftol, xtol=xtol, gtol=gtol)
            if not restarts:
                return
            u = rng.random(len(xl))
