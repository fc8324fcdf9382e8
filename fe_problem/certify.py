"""A reference solve that certifies the minimum of an updating problem (the suite's f_opt).

J is a sum of squares: the weighted relative frequency errors, plus shape_weight (1 - MAC_i)
per mode with a measured shape. `ModalJacobian.residuals` writes J as r.r (the shape terms as
`UpdatingProblem.shape_residuals`, smooth where MAC -> 1), so scipy's bounded trust-region
least squares (`scipy.optimize.least_squares`, method "trf") can drive it to the floor of
double precision. The Jacobian is analytic (`ModalJacobian`: eigenvalue derivatives, and
Nelson's shape derivatives through adjoint solves of the bordered matrix), one eigen-solve and
a sparse LU per measured mode instead of the 2 n_var eigen-solves of a central difference
(`jacobian="fd"`, with the sqrt(1 - MAC) residuals of `residual_vector`: the method of the
first certificates, kept for comparison).

Each start runs the bounded trust region (a quarter of `max_nfev`), then L-BFGS-B (which
settles the active bounds), then Levenberg-Marquardt on the free variables alone (with those
on a bound whose gradient points into the box; its end clipped to the box; the bounded trust
region where the free variables outnumber the residuals), these two
again while a round still lowers J by more than 4 eps J (at most `ROUNDS`). `certify_minimum` runs that solve
from several starts (the initial model, the hidden truth where known, perturbed truths and
seeded uniform draws in the bounds) and returns the lowest J and its precision: the spread of
the ends within a relative 1e-8 of the lowest (independent starts that agree to it have found
the same minimum; a basin one start alone found is claimed to 1e-8 relative), never below the
rounding of J itself (4 eps J) nor twice J's evaluation noise at the best point (`evaluation_noise`).
It is the best of N starts, not a proof of global optimality: the certificate also states
first-order optimality at its point (`projected_gradient`). A problem on the sparse solver
path is solved on its dense twin (`reported=`: ARPACK's tolerance leaves J a noise of 1e-12
at 192 parameters, enough to stall the line searches), its minimum then J of the reported
problem at the best point.
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


class ModalJacobian:
    """The residuals of `residual_vector` and their exact derivatives d r / d theta at one point:
    frequencies from d lambda_i = phi_i^T (dK_k - lambda_i dM_k) phi_i, shapes from Nelson's
    method (the derivative of each mass-normalised shape solved from the bordered matrix
    [[K - lambda_i M, M phi_i], [phi_i^T M, 0]], one sparse LU per paired mode with a measured
    shape; as only the measured rows are needed, the matrix being symmetric, one adjoint solve
    per measured row serves every parameter), then through the normalisation of
    `UpdatingProblem.shape_residuals`. One eigen-solve (counted as one evaluation) instead of the
    2 n_var of a central difference. The affine derivative matrices dK_k, dM_k are the model's
    own triplets (`Terms`), on either solver path. Needs simple eigenvalues for the modes it
    differentiates (Nelson's method does): `certify_minimum` checks it against a central
    difference at every start (`JAC_RTOL`)."""

    def __init__(self, problem):
        import scipy.sparse as sp

        from .terms import Terms

        self.problem = problem
        system = problem.system
        (kr, kc, kv, kt), (mr, mc, mv, mt) = Terms(system.model, system.parameters).free_arrays()
        n, p = system.n_free, len(system.parameters)
        self.n, self.p = n, p
        self._k = (kr, kc, kv, kt)
        self._m = (mr, mc, mv, mt)
        # every dK_k stacked into one (p n, n) sparse matrix: dK phi for all k is one product
        on, om = kt >= 0, mt >= 0
        self.dk = sp.csr_matrix((kv[on], (kt[on] * n + kr[on], kc[on])), shape=(p * n, n))
        self.dm = sp.csr_matrix((mv[om], (mt[om] * n + mr[om], mc[om])), shape=(p * n, n))
        self.mass_constant = self.dm.nnz == 0

    def _matrix(self, trip, theta):
        import scipy.sparse as sp

        r, c, v, t = trip
        return sp.csc_matrix((v * np.append(theta, 1.0)[t], (r, c)), shape=(self.n, self.n))

    def residuals(self, X) -> np.ndarray:
        """Residuals (n, m + s * q) whose squares sum to J (`UpdatingProblem.objective_from_modes`):
        the weighted frequency errors, then `shape_residuals`; counts n evaluations."""
        pr = self.problem
        X = pr.check_x(X)
        f, phi = pr._solve(X, shapes=bool(pr.shape_weight))
        pr.n_evals += X.shape[0]
        fm = pr.data.frequencies_hz
        r = np.sqrt(pr.weights) * (fm - f) / fm
        return np.hstack([r, pr.shape_residuals(phi)]) if pr.shape_weight else r

    def __call__(self, x) -> tuple[np.ndarray, np.ndarray]:
        """(r, dr/dtheta) at x (n_var,): r as `residuals`, the Jacobian (len(r), n_var)."""
        import scipy.sparse as sp
        from scipy.sparse.linalg import splu

        from .modal import frequencies_hz
        from .solver import take_rows

        pr = self.problem
        x = pr.check_x(x, "x")[0]
        lam, phi = pr.system.eigen(x[None], pr.n_model_modes, vectors=True)  # all free DOFs
        pr.n_evals += 1
        lam, phi = lam[0], phi[0]
        n, p = self.n, self.p
        idx = pr.model_index
        fm, sw = pr.data.frequencies_hz, np.sqrt(pr.weights)
        modes = phi[:, idx]                                        # (n, m) the paired modes
        dkp = (self.dk @ modes).reshape(p, n, -1)                  # dK_k phi_i: (p, n, m)
        dmp = (self.dm @ modes).reshape(p, n, -1)
        dlam = np.einsum("ni,pni->ip", modes, dkp) - lam[idx, None] * np.einsum("ni,pni->ip", modes, dmp)
        f = frequencies_hz(lam)[idx]
        r = sw * (fm - f) / fm
        jac = -(sw / fm / (8.0 * np.pi ** 2 * f))[:, None] * dlam
        if not pr.shape_weight:
            return r, jac
        K, M = self._matrix(self._k, x), self._matrix(self._m, x)
        sel = np.flatnonzero(pr.has_shape)
        rows = pr.rows
        dphi_rows = np.zeros((p, len(rows), len(sel)))             # d phi_i at the measured rows
        ok = rows >= 0                                             # a supported DOF's entry stays 0
        pick = np.zeros((n + 1, int(ok.sum())))                    # [C^T; 0]: the measured rows
        pick[rows[ok], np.arange(int(ok.sum()))] = 1.0
        for j, s in enumerate(sel):
            i = idx[s]
            mphi = M @ phi[:, i]
            bordered = sp.bmat([[K - lam[i] * M, sp.csc_matrix(mphi[:, None])],
                                [sp.csc_matrix(mphi[None, :]), None]], format="csc")
            # (K - lam M) dphi = -(dK - lam dM - dlam M) phi, phi^T M dphi = -phi^T dM phi / 2
            rhs = -(dkp[:, :, s] - lam[i] * dmp[:, :, s] - dlam[s][:, None] * mphi[None, :])
            rhs = np.hstack([rhs, -0.5 * (dmp[:, :, s] @ phi[:, i])[:, None]])    # (p, n + 1)
            # only C dphi is needed: the bordered matrix is symmetric, so C dphi = G^T rhs with
            # G = bordered^-1 [C^T; 0], one solve per measured row instead of one per parameter
            adjoint = splu(bordered).solve(pick)                                  # (n + 1, q)
            dphi_rows[:, ok, j] = rhs @ adjoint
        # the shape residuals sqrt(w) (a - (a.b) b), b = v / |v|, v the model shape at the rows
        v = take_rows(phi[None], rows)[0][:, idx[sel]]             # (q, s)
        meas = pr.data.shapes[:, sel]
        a = meas / np.linalg.norm(meas, axis=0)
        nv = np.linalg.norm(v, axis=0)
        b = v / nv
        ab = np.sum(a * b, axis=0)
        db = (dphi_rows - b[None] * np.einsum("qs,pqs->ps", b, dphi_rows)[:, None, :]) / nv  # (p, q, s)
        adb = np.einsum("qs,pqs->ps", a, db)
        dr = -np.sqrt(pr.shape_weight) * (adb[:, None, :] * b[None] + ab[None, None, :] * db)  # (p, q, s)
        rs = pr.shape_residuals(take_rows(phi[None], rows))[0]
        jac_s = dr.transpose(0, 2, 1).reshape(p, -1).T             # rows ordered as shape_residuals
        return np.concatenate([r, rs]), np.vstack([jac, jac_s])


#: A start's first analytic Jacobian is compared with a central difference (a step of
#: `CHECK_STEP` in the unit box, in 8 of its columns evenly spaced); a largest difference above
#: this fraction of the largest entry stops the solve (a repeated eigenvalue, where Nelson's
#: method does not hold). tests/test_certify.py measures 2e-7 on either solver path; the
#: value at each start is stored with the certificate (`jacobian_check`).
JAC_RTOL = 1e-2
#: The step of that check (the sparse path's eigenvalues carry ARPACK's tolerance: a smaller
#: step is noisier).
CHECK_STEP = 1e-3

#: The relative size of the perturbations of the truth that `perturbed` starts draw.
PERTURBATION = 0.05

#: Rounds of L-BFGS-B and the polish on the free variables per start (fewer when a round no
#: longer lowers J by more than its rounding).
ROUNDS = 6
#: J's noise at the best point is measured on `NOISE_POINTS` points whose coordinates lie within
#: a relative `NOISE_STEP` of it (clipped to the bounds; J's smooth change there is far below its
#: rounding): the range of J there is the evaluation's own noise (the rounding of 1 - MAC on the
#: dense path, 1e-14 at 12 parameters; ARPACK's tolerance on the sparse one, 1e-12 at 96 and 192).
NOISE_STEP = 1e-12
NOISE_POINTS = 64
#: The precision is at least this many times that range: a margin for the extremes the draws did
#: not reach (32 other draws at 96/5 went 1.1 times the range of the first 16 below J(x)).
NOISE_FACTOR = 2.0


@dataclass(frozen=True)
class Certificate:
    """The lowest J found (`f_min`), where (`x`, Pa), its precision (the spread of the ends in
    the lowest basin, at least the rounding of J), every start's end J and where it started
    (`kinds`: x0, truth, perturbed, random), the largest violation of first-order optimality at
    `x` in the unit box (`projected_gradient`: |dJ/du| of a free variable, the part of it that
    points out of the box at a bound) and the largest relative difference between the analytic
    Jacobian and a central difference at the starts (`jacobian_check`, None with
    jacobian="fd"), J's evaluation noise at `x` (`noise`, `evaluation_noise`) and the solver
    path the starts ran on (`solved_on`: "dense" or "sparse")."""

    f_min: float
    precision: float
    x: np.ndarray
    ends: tuple[float, ...]
    kinds: tuple[str, ...] = ()
    projected_gradient: float | None = None
    jacobian_check: float | None = None
    noise: float | None = None
    solved_on: str | None = None

    def to_dict(self) -> dict:
        return {"f_opt": self.f_min, "precision": self.precision, "starts": len(self.ends),
                "ends": list(self.ends)}


def projected_gradient(g: np.ndarray, u: np.ndarray, at: float = 1e-9) -> float:
    """The largest violation of first-order optimality of gradient g (in the unit box) at u:
    |g_i| of a free variable, max(-g_i, 0) at the lower bound, max(g_i, 0) at the upper."""
    v = np.where(u <= at, np.maximum(-g, 0.0), np.where(u >= 1 - at, np.maximum(g, 0.0), np.abs(g)))
    return float(v.max()) if v.size else 0.0


def evaluation_noise(problem, x, seed: int = 0) -> tuple[float, float]:
    """(J(x), the range of J over x and `NOISE_POINTS` points with every coordinate moved by a
    relative uniform +-`NOISE_STEP`, clipped to the bounds): how far J's own rounding moves it
    near x, so how far below J(x) a run may see J near x without being lower in truth."""
    rng = np.random.default_rng([seed, 2])
    x = np.asarray(x, float)
    X = np.vstack([x, x * (1 + NOISE_STEP * rng.uniform(-1, 1, (NOISE_POINTS, len(x))))])
    f = problem.evaluate(np.clip(X, problem.xl, problem.xu))
    return float(f[0]), float(f.max() - f.min())


def certify_minimum(problem, starts: int = 4, seed: int = 0, truth=None, max_nfev: int = 200,
                    perturbed: int = 0, jacobian: str = "analytic", reported=None) -> Certificate:
    """Multi-start bounded least squares on `problem` (an UpdatingProblem) from its x0, the
    truth (if given), `perturbed` draws around the truth (each modulus times 1 + a uniform
    +-`PERTURBATION`, clipped to the bounds) and `starts` seeded uniform draws; see the module
    docstring. `jacobian`: "analytic" (`ModalJacobian` for a problem with shapes, the problem's
    own eigenvalue derivatives without) or "fd" (the central difference of `residual_vector`,
    2 n_var solves per Jacobian; the method of the certificates of version 1).

    `reported`: the problem whose minimum is certified, when the starts run on a twin of it on
    another solver path (the dense one, whose J carries only rounding where the sparse path's
    carries ARPACK's tolerance, 1e-12 at 192 parameters, enough to stall the line searches
    short of the minimum). The minimum is then J of `reported` at the best point, and the
    precision also covers the two paths' difference there and `reported`'s noise."""
    from scipy.optimize import least_squares, minimize

    if jacobian not in ("analytic", "fd"):
        raise ValueError(f"jacobian must be 'analytic' or 'fd', got {jacobian!r}")
    xl, xu = np.asarray(problem.xl, float), np.asarray(problem.xu, float)
    span = xu - xl
    n = len(xl)
    modal = ModalJacobian(problem) if jacobian == "analytic" and problem.shape_weight else None
    cols = np.arange(0, n, max(1, n // 8))  # the columns the start's check compares
    cache: dict = {}

    def x_of(u):
        return xl + np.clip(u, 0, 1) * span

    def fun(u):
        if modal is not None:
            hit = cache.get(np.clip(u, 0, 1).tobytes())
            return hit[0] if hit is not None else modal.residuals(x_of(u))[0]
        return residual_vector(problem, x_of(u))[0]

    def fd_jac(u, res):
        u = np.clip(u, STEP, 1 - STEP)  # the central points stay inside the bounds
        U = np.vstack([u + STEP * np.eye(n), u - STEP * np.eye(n)])
        R = res(xl + U * span)
        return ((R[:n] - R[n:]) / (2 * STEP)).T

    def jac(u):
        if not problem.shape_weight:  # frequencies only: the analytic Jacobian (one eigen-solve)
            return problem.least_squares(x_of(u)).jacobian * span
        if modal is None:
            return fd_jac(u, lambda X: residual_vector(problem, X))
        key = np.clip(u, 0, 1).tobytes()
        if key not in cache:  # the solvers ask for fun and jac at one point: one solve with vectors
            cache.clear()
            r, j = modal(x_of(u))
            cache[key] = (r, j * span)
        return cache[key][1]

    def value_grad(u):
        g = jac(u)  # first: with the analytic Jacobian, fun then reads the residuals it cached
        r = fun(u)
        return float(r @ r), 2.0 * g.T @ r

    rng = np.random.default_rng(seed)
    points = [(np.asarray(problem.x0, float), "x0")]
    if truth is not None:
        t = np.asarray(truth, float)
        points.append((t, "truth"))
        near = np.random.default_rng([seed, 1])  # its own stream: the uniform draws stay those of version 1
        points += [(np.clip(t * (1 + near.uniform(-PERTURBATION, PERTURBATION, n)), xl, xu), "perturbed")
                   for _ in range(perturbed)]
    points += [(rng.uniform(xl, xu), "random") for _ in range(starts)]
    ends, best_x, best_pg, checks = [], None, None, []
    for x, _ in points:
        u = (x - xl) / span
        if modal is not None:  # Nelson's derivative holds at this start (simple eigenvalues)
            w = np.clip(u, CHECK_STEP, 1 - CHECK_STEP)[None] + CHECK_STEP * np.eye(n)[cols]
            R = modal.residuals(xl + np.vstack([w, w - 2 * CHECK_STEP * np.eye(n)[cols]]) * span)
            d = ((R[:len(cols)] - R[len(cols):]) / (2 * CHECK_STEP)).T
            a = jac(np.clip(u, CHECK_STEP, 1 - CHECK_STEP))[:, cols]
            checks.append(float(np.abs(a - d).max() / max(np.abs(d).max(), 1e-300)))
            if checks[-1] > JAC_RTOL:
                raise RuntimeError(f"the analytic Jacobian differs from a central difference by {checks[-1]:.2g} "
                                   f"of its largest entry at a start (> {JAC_RTOL}); run with jacobian='fd'")
        # 1. bounded trust region from afar; 2. L-BFGS-B settles which bounds are active (the
        # trust region crawls along them); 3. Levenberg-Marquardt on the free variables alone
        # converges to the last bits (J's residual is not zero: Gauss-Newton alone is linear);
        # 2 and 3 again while a round still lowers J by more than its rounding (4 eps J)
        u = least_squares(fun, u, jac=jac, bounds=(0.0, 1.0), method="trf", ftol=1e-15,
                          xtol=1e-15, gtol=1e-15, max_nfev=max_nfev // 4).x
        f = float(np.sum(fun(u) ** 2))
        for _ in range(ROUNDS if modal is not None else 1):
            if f < 1e-20:  # a zero residual reached: nothing to polish
                break
            u = minimize(value_grad, u, jac=True, method="L-BFGS-B", bounds=[(0.0, 1.0)] * n,
                         options={"ftol": 1e-16, "gtol": 1e-14, "maxiter": max_nfev, "maxcor": 30}).x
            # the free variables, and those on a bound whose gradient points into the box (the
            # active set's update: L-BFGS-B's line search can fail before it frees them, as at
            # 192/1 from the truth, which then stopped 1.9e-9 above the minimum)
            g = 2.0 * jac(u).T @ fun(u)
            free = ((u > 1e-9) & (u < 1 - 1e-9)) | ((u <= 1e-9) & (g < 0)) | ((u >= 1 - 1e-9) & (g > 0))
            if free.any():
                def sub(v, u=u, free=free):
                    w = u.copy()
                    w[free] = v
                    return w
                # LM needs no fewer residuals than variables; with more free variables than
                # residuals (192 moduli, 128 residuals) the bounded trust region polishes them
                wide = free.sum() > len(fun(u))
                v = least_squares(lambda v: fun(sub(v)), u[free], jac=lambda v: jac(sub(v))[:, free],
                                  method="trf" if wide else "lm", bounds=(0.0, 1.0) if wide else (-np.inf, np.inf),
                                  ftol=1e-15, xtol=1e-15, gtol=1e-15, max_nfev=max_nfev).x
                v = np.clip(v, 0.0, 1.0)  # LM ignores the bounds: a variable it pushed past one sits on it
                if np.sum(fun(sub(v)) ** 2) <= np.sum(fun(u) ** 2):
                    u = sub(v)
            before, f = f, float(np.sum(fun(u) ** 2))
            if before - f <= 4 * np.finfo(float).eps * f:
                break
        r = fun(u)
        pg = projected_gradient(2.0 * jac(u).T @ r, np.clip(u, 0, 1))
        if not ends or f < min(ends):
            best_x, best_pg = x_of(u), pg
        ends.append(f)
    low = min(ends)
    # the ends in the lowest basin (within a relative 1e-8, or below 1e-20): their spread is the
    # precision; a basin one start alone found is claimed to its relative 1e-8 only
    same = [f for f in ends if f - low <= max(1e-8 * low, 1e-20)]
    spread = max(same) - low if len(same) >= 2 else 1e-8 * low
    # J's own noise at the best point (and, solved on a twin, J of the reported problem there
    # and the two paths' difference): a run may see J that much below the minimum found
    at, noise = evaluation_noise(problem if reported is None else reported, best_x, seed)
    f_min, gap = (low if reported is None else at), abs(at - low)
    if low < 1e-20:  # a zero residual: J there is rounding, no noise to measure
        f_min, noise, gap = low, 0.0, 0.0
    precision = max(spread, NOISE_FACTOR * noise, gap, 4 * np.finfo(float).eps * f_min, np.finfo(float).tiny)
    return Certificate(f_min, float(precision), best_x, tuple(ends), tuple(k for _, k in points), best_pg,
                       max(checks) if checks else None, noise, problem.system.path)
