"""A reference solve that certifies the minimum of an updating problem (the suite's f_opt).

J is a sum of squares: the weighted relative frequency errors, plus shape_weight (1 - MAC_i)
per mode with a measured shape. `residual_vector` writes J as r.r (the shape terms as
sqrt(shape_weight (1 - MAC_i))), so scipy's bounded trust-region least squares
(`scipy.optimize.least_squares`, method "trf") can drive it to the floor of double precision.
The Jacobian is the problem's analytic one for frequencies only, else a central finite
difference in the unit box, all 2 n_var points solved in one vectorised batch.

Each start runs the bounded trust region (a quarter of `max_nfev`), then L-BFGS-B (which
settles the active bounds), then Levenberg-Marquardt on the free variables alone.
`certify_minimum` runs that solve from several starts (the initial model, the hidden truth
where known, and seeded uniform draws in the bounds) and returns the lowest J and its precision:
the spread of the ends within a relative 1e-8 of the lowest (independent starts that agree to
it have found the same minimum; a basin one start alone found is claimed to 1e-8 relative),
never below the rounding of J itself (4 eps J).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Central-difference step in the unit box (a step of the float cube root of eps).
STEP = 6e-6


def residual_vector(problem, X) -> np.ndarray:
    """Residuals (n, m + s) whose squares sum to J for points X (n, n_var); counts n evaluations."""
    X = problem.check_x(X)
    f, phi = problem._solve(X, shapes=bool(problem.shape_weight))
    problem.n_evals += X.shape[0]
    fm = problem.data.frequencies_hz
    r = np.sqrt(problem.weights) * (fm - f) / fm
    if not problem.shape_weight:
        return r
    from .correlation import mac

    sel = np.flatnonzero(problem.has_shape)
    macs = np.einsum("bii->bi", mac(problem.data.shapes[:, sel][None], phi[:, :, problem.model_index[sel]]))
    return np.hstack([r, np.sqrt(problem.shape_weight * np.clip(1.0 - macs, 0.0, None))])


@dataclass(frozen=True)
class Certificate:
    """The lowest J found (`f_min`), where (`x`, Pa), its precision (the spread of the ends in
    the lowest basin, at least the rounding of J), and every start's end J."""

    f_min: float
    precision: float
    x: np.ndarray
    ends: tuple[float, ...]

    def to_dict(self) -> dict:
        return {"f_opt": self.f_min, "precision": self.precision, "starts": len(self.ends),
                "ends": list(self.ends)}


def certify_minimum(problem, starts: int = 4, seed: int = 0, truth=None, max_nfev: int = 200) -> Certificate:
    """Multi-start bounded least squares on `problem` (an UpdatingProblem) from its x0, the
    truth (if given) and `starts` seeded uniform draws; see the module docstring."""
    from scipy.optimize import least_squares, minimize

    xl, xu = np.asarray(problem.xl, float), np.asarray(problem.xu, float)
    span = xu - xl
    n = len(xl)

    def fun(u):
        return residual_vector(problem, xl + np.clip(u, 0, 1) * span)[0]

    def jac(u):
        if not problem.shape_weight:  # frequencies only: the analytic Jacobian (one eigen-solve)
            return problem.least_squares(xl + np.clip(u, 0, 1) * span).jacobian * span
        u = np.clip(u, STEP, 1 - STEP)  # the central points stay inside the bounds
        U = np.vstack([u + STEP * np.eye(n), u - STEP * np.eye(n)])
        R = residual_vector(problem, xl + U * span)
        return ((R[:n] - R[n:]) / (2 * STEP)).T

    def value_grad(u):
        r = fun(u)
        return float(r @ r), 2.0 * jac(u).T @ r

    rng = np.random.default_rng(seed)
    points = [np.asarray(problem.x0, float)] + ([np.asarray(truth, float)] if truth is not None else [])
    points += [rng.uniform(xl, xu) for _ in range(starts)]
    ends, best_x = [], None
    for x in points:
        # 1. bounded trust region from afar; 2. L-BFGS-B settles which bounds are active (the
        # trust region crawls along them); 3. Levenberg-Marquardt on the free variables alone
        # converges to the last bits (J's residual is not zero: Gauss-Newton alone is linear)
        u = least_squares(fun, (x - xl) / span, jac=jac, bounds=(0.0, 1.0), method="trf", ftol=1e-15,
                          xtol=1e-15, gtol=1e-15, max_nfev=max_nfev // 4).x
        done = float(np.sum(fun(u) ** 2)) < 1e-20  # a zero residual reached: nothing to polish
        if not done:
            u = minimize(value_grad, u, jac=True, method="L-BFGS-B", bounds=[(0.0, 1.0)] * n,
                         options={"ftol": 1e-16, "gtol": 1e-14, "maxiter": max_nfev, "maxcor": 30}).x
        free = (u > 1e-9) & (u < 1 - 1e-9)
        if not done and free.any() and free.sum() <= len(fun(u)):  # LM needs no fewer residuals than variables
            def sub(v, u=u, free=free):
                w = u.copy()
                w[free] = v
                return w
            v = least_squares(lambda v: fun(sub(v)), u[free], jac=lambda v: jac(sub(v))[:, free], method="lm",
                              ftol=1e-15, xtol=1e-15, gtol=1e-15, max_nfev=max_nfev).x
            if np.all((v >= 0) & (v <= 1)) and np.sum(fun(sub(v)) ** 2) <= np.sum(fun(u) ** 2):
                u = sub(v)
        f = float(np.sum(fun(u) ** 2))
        if not ends or f < min(ends):
            best_x = xl + np.clip(u, 0, 1) * span
        ends.append(f)
    low = min(ends)
    # the ends in the lowest basin (within a relative 1e-8, or below 1e-20): their spread is the
    # precision; a basin one start alone found is claimed to its relative 1e-8 only
    same = [f for f in ends if f - low <= max(1e-8 * low, 1e-20)]
    spread = max(same) - low if len(same) >= 2 else 1e-8 * low
    precision = max(spread, 4 * np.finfo(float).eps * low, np.finfo(float).tiny)
    return Certificate(low, float(precision), best_x, tuple(ends))
