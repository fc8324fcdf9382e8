""""Every member", sparse: which members changed when several did, by sparse Bayesian learning.

The class's parameters are every element's relative modulus change, E_e = E0_e (1 + theta_e),
theta_e in [LOW, HIGH] (a modulus ratio 0.1 to 4). The residuals r(theta) are the diagnosis's
(global scale profiled out, `fit.profiled`).

1. Localise: Gauss-Newton with sparse Bayesian learning. At theta_k the Jacobian J_k (forward
   differences, one batched eigen-solve of n + 1 models, the calibrated pairing held); the
   linearised problem y = J_k theta + e, y = J_k theta_k - r(theta_k), is solved by automatic
   relevance determination (`ard`: a zero-mean Gaussian prior of its own precision on every
   member, Tipping 2001, MacKay's fixed-point updates, the noise precision estimated; the updates
   of scikit-learn's `ARDRegression`, against which a test checks it: importing scikit-learn took
   11-14 s on the shared machine, longer than a diagnosis), which prunes the members whose prior
   precision exceeds `THRESHOLD_LAMBDA` (a change of less than about 1 % std). Repeated until
   theta settles (at most `MAX_ITERATIONS`).
2. Refit the members kept (the support) by bounded nonlinear least squares, the rest nominal
   (the modes paired afresh and the fit repeated when its pairing differs from the start's);
   then prune backwards by evidence: drop the member whose removal raises the class's evidence
   (below) most, refit, until no removal raises it. ARD's linearised, noise-estimated view keeps
   members that only take up a misfit of the model's form (a member whose bending alone changed,
   read as a modulus of axial and bending stiffness together: 8 members kept for 3 changed).
3. Evidence, comparable with the other classes (evidence.py): Laplace at the refit, the
   Gauss-Newton Hessian 2 J^T J (so the posterior covariance D (J^T J)^-1), each member's
   Gaussian truncated to its prior, a uniform one on the side its change lies on as the local
   family's (`sided`: a loss in [LOW, 0], the ``stiffness_loss`` candidate's range; a gain in
   [0, HIGH], the ``stiffness_gain`` candidate's: the local family has a class of each side for
   every member, so a member's change is judged on the same range in both); less log C(n, k):
   the class "k of the n members changed" spreads its prior over every support of k members,
   and the sum over supports is at least the chosen one's term divided by C(n, k), so the value
   is a lower bound on that class's evidence. Before, each member had the full range [LOW,
   HIGH]: two members (2 and 9 of the H-frame, 0.81 and 0.75) localised right came out 1.6
   below one of them alone, the answer. (A charge of log C(n, k) - log n, the weight of "one
   member changed" for every k, made the class beat "every storey free" on a four-storey shear
   frame measured at 4 floors, seed 2 of tests/test_diagnosis_spread.py, with 4 of its 12
   members at ratios 0.16 to 3.6: the data cannot tell a storey's two columns apart.) (ARD's own marginal likelihood is not used for the ranking: its Gaussian
   prior's widths are fitted to the data, which overstates the evidence against classes with a
   fixed prior.)

Only where a solve is cheap (the dense solver path) and for planar models, as the distributed
classes (groups.py): the Jacobian costs one batched solve of n + 1 models per iteration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import norm

from ..assembly import AffineModel, solver_path
from ..correlation import correlate
from ..parameters import Parameter
from .setting import Setting, solve
from .evidence import ScoredClass, sides_log_prior
from .fit import profiled
from .residuals import Observations

#: The prior range of each member's relative modulus change (a modulus ratio 0.1 to 4).
LOW, HIGH = -0.9, 3.0
#: ARD prunes a member whose prior precision exceeds this (1 / 0.01^2: a change below ~1 % std).
THRESHOLD_LAMBDA = 1.0e4
#: Gauss-Newton + ARD iterations at most, and the change of theta that ends them.
MAX_ITERATIONS, THETA_TOL = 8, 1e-4
#: Forward-difference step of the Jacobian (relative modulus change).
STEP = 1e-4
#: Refits of `refit` with the pairing its fit gives, at most.
REPAIRS = 3
#: The class's label's kind, and its family in the evidence table.
KIND, FAMILY = "every_member_sparse", "sparse"


@dataclass(frozen=True, eq=False)
class SparseFit:
    """The members localised (element ids), their relative modulus changes theta and std, the
    chi^2 of the refit (pairing afresh), the Gauss-Newton + ARD iterations, the number of
    members the support was chosen from, the Jacobian at the refit and the support's charge
    log C(n, k) (the Laplace factor, `log_occam`; see the module docstring)."""

    members: tuple[int, ...]
    theta: np.ndarray
    theta_std: np.ndarray
    chi2: float
    s: float
    iterations: int
    n_members: int
    jacobian: np.ndarray        # (n_residuals, k) at the refit
    support_log_penalty: float  # log C(n, k)

    @property
    def label(self) -> str:
        return f"{KIND}@members={'+'.join(str(e) for e in self.members)}"

    def log_occam(self, dispersion: float) -> float:
        """log of the Laplace integral of exp(-(chi^2 - chi^2^) / (2 D)) over the prior (`sided`),
        less the support's charge, log C(n, k) (see the module docstring), and the sides' (each
        member's, a loss or a gain: `evidence.sides_log_prior`)."""
        return (log_occam(self.theta, self.jacobian, self.n_members, dispersion, *sided(self.theta))
                + sides_log_prior(len(self.theta)))

    def scored(self, chi2_base: float, dispersion: float, held_out_error_pct: float | None = None) -> ScoredClass:
        """The class's row of the evidence table (log evidence against the calibrated model)."""
        return ScoredClass(self.label, FAMILY, len(self.members), self.chi2,
                           -(self.chi2 - chi2_base) / (2 * dispersion) + self.log_occam(dispersion),
                           self.estimate(), held_out_error_pct)

    def estimate(self) -> dict:
        """The members, each one's modulus ratio 1 + theta with its std, the scale, the iterations."""
        return {"members": list(self.members), "modulus_ratio": [float(1 + t) for t in self.theta],
                "modulus_ratio_std": [float(x) for x in self.theta_std], "global_scale": self.s,
                "iterations": self.iterations, "support_log_penalty": self.support_log_penalty}


def ard(x: np.ndarray, y: np.ndarray, threshold_lambda: float = THRESHOLD_LAMBDA, max_iter: int = 300,
        tol: float = 1e-3, hyper: float = 1e-6) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Sparse Bayesian learning (automatic relevance determination) of y = x w + e.

    Prior w_i ~ N(0, 1 / lambda_i), noise e ~ N(0, 1 / alpha), Gamma(hyper, hyper) hyperpriors on
    every lambda_i and on alpha. MacKay's fixed-point updates (Tipping 2001, eq. 16; Bishop 2006,
    section 7.2.2): posterior Sigma = (diag(lambda) + alpha x^T x)^-1, mean m = alpha Sigma x^T y,
    gamma_i = 1 - lambda_i Sigma_ii, lambda_i = (gamma_i + 2 hyper) / (m_i^2 + 2 hyper),
    alpha = (n - sum gamma + 2 hyper) / (|y - x m|^2 + 2 hyper); a weight whose lambda_i exceeds
    `threshold_lambda` is pruned (set to 0, its column dropped). Stops when sum |m - m_old| < tol.
    Returns (w (p,), lambda (p,), Sigma of the kept weights, alpha)."""
    n, p = x.shape
    w = np.zeros(p)
    lam = np.ones(p)
    alpha = 1.0 / (np.var(y) + np.finfo(float).eps)
    keep = np.ones(p, dtype=bool)

    def posterior():
        xk = x[:, keep]
        sigma = np.linalg.inv(np.diag(lam[keep]) + alpha * xk.T @ xk)
        out = np.zeros(p)
        out[keep] = alpha * sigma @ (xk.T @ y)
        return sigma, out

    sigma = np.zeros((0, 0))
    for it in range(max_iter):
        sigma, w_new = posterior()
        gamma = 1.0 - lam[keep] * np.diag(sigma)
        lam[keep] = (gamma + 2 * hyper) / (w_new[keep] ** 2 + 2 * hyper)
        alpha = (n - gamma.sum() + 2 * hyper) / (float(np.sum((y - x @ w_new) ** 2)) + 2 * hyper)
        keep = lam < threshold_lambda
        w_new[~keep] = 0.0
        converged = it > 0 and np.sum(np.abs(w_new - w)) < tol
        w = w_new
        if converged or not keep.any():
            break
    if keep.any():
        sigma, w = posterior()
    return w, lam, sigma, float(alpha)


def sided(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each member's prior range as the local family's, by the side its change lies on: a loss in
    [LOW, 0] (the ``stiffness_loss`` candidate's [0, 0.9]), a gain in [0, HIGH] (the
    ``stiffness_gain`` candidate's [0, 3]). The local family has a class of each side for every
    member (a label each, each of the prior weight of no effect); so has a support here."""
    loss = np.asarray(theta) < 0.0
    return np.where(loss, LOW, 0.0), np.where(loss, 0.0, HIGH)


def log_occam(theta: np.ndarray, jacobian: np.ndarray, n_members: int, dispersion: float,
              low=LOW, high=HIGH) -> float:
    """The Laplace factor of a support (the members of `theta`, with the residuals' `jacobian` at
    the fit): log of the integral of exp(-(chi^2 - chi^2^) / (2 D)) over the uniform prior on
    [low, high] for each member (default [LOW, HIGH]; scalars or one bound per member), each
    member's Gaussian truncated to it, less log C(n, k)."""
    k = len(theta)
    low, high = np.broadcast_to(np.asarray(low, float), (k,)), np.broadcast_to(np.asarray(high, float), (k,))
    jtj = jacobian.T @ jacobian
    sign, logdet_jtj = np.linalg.slogdet(jtj)
    if sign <= 0:
        return -np.inf
    sd = np.sqrt(dispersion * np.diag(np.linalg.inv(jtj)))
    mass = norm.cdf((high - theta) / sd) - norm.cdf((low - theta) / sd)
    log_gauss = 0.5 * k * np.log(2 * np.pi) + 0.5 * (k * np.log(dispersion) - logdet_jtj)
    return float(log_gauss + np.sum(np.log(np.maximum(mass, 1e-300))) - np.sum(np.log(high - low))
                 - math.log(math.comb(n_members, k)))


class _AllMembers:
    """Every element's modulus as a parameter of one affine system; residuals for batches of theta.

    weights (n_elements, p), names (p,): the class's p parameters each change the moduli of the
    elements its column weights, E = E0 (1 + weights theta) (group_free.py: one per storey);
    default one parameter per element, named by its id."""

    def __init__(self, st: Setting, weights: np.ndarray | None = None, names=None):
        model = st.model
        self.st = st
        self.ids = list(model.element_ids)
        self.e0 = np.array([model.element_modulus_pa(e) for e in self.ids])
        self.system = AffineModel(model, tuple(Parameter("modulus", (e,), 1e-3 * v, 1e3 * v, v, name=f"E{e}")
                                               for e, v in zip(self.ids, self.e0)))
        self.weights = weights
        self.names = list(self.ids) if names is None else list(names)

    def modes(self, theta: np.ndarray):
        """Frequencies (b, k) and shapes at the measured coordinates for theta (b, p)."""
        change = theta if self.weights is None else theta @ self.weights.T
        return solve(self.system, self.e0[None, :] * (1.0 + change), self.st.coords, self.st.n_modes)

    def residuals(self, obs: Observations, theta: np.ndarray, pairing=None) -> list:
        """The profiled fits (`fit.Fit`, a = 0) of theta (b, n), one batched solve."""
        hz, sh = self.modes(np.atleast_2d(theta))
        return [profiled(obs, hz[i], sh[i], pairing) for i in range(hz.shape[0])]

    def jacobian(self, obs: Observations, theta: np.ndarray, cols: np.ndarray, pairing) -> tuple:
        """r(theta) and dr/dtheta for the members `cols` (forward differences, one batched solve)."""
        batch = np.repeat(theta[None, :], len(cols) + 1, axis=0)
        batch[1 + np.arange(len(cols)), cols] += STEP
        fits = self.residuals(obs, batch, pairing)
        r0 = fits[0].residuals
        return r0, np.column_stack([(f.residuals - r0) / STEP for f in fits[1:]])


def applicable(st: Setting) -> bool:
    """Planar models on the dense solver path (see the module docstring)."""
    return (st.model.layout.planar and len(st.model.elements) >= 2
            and solver_path(len(st.local.dofmap.free)) == "dense")


def fit_sparse(st: Setting, obs: Observations, base_pairing: np.ndarray, am=None) -> SparseFit | None:
    """Localise the changed members (ARD on the linearised problem, iterated), refit them; None
    when the model is not one this class handles or ARD keeps no member. am: the class's
    parameters (default every member of a frame, `_AllMembers`; a matrix model's terms,
    matrix.AllTerms: the same interface)."""
    if am is None:
        if not applicable(st):
            return None
        am = _AllMembers(st)
    n = len(am.ids)
    theta = np.zeros(n)
    every = np.arange(n)
    support = every
    it = 0
    for it in range(1, MAX_ITERATIONS + 1):
        r, jac = am.jacobian(obs, theta, every, base_pairing)
        y = jac @ theta - r
        new = np.clip(ard(jac, y, tol=1e-8, max_iter=500)[0], LOW, HIGH)
        support = np.flatnonzero(new != 0.0)
        done = np.max(np.abs(new - theta)) < THETA_TOL
        theta = new
        if done:
            break
    if not len(support):
        return None
    best = refit(am, obs, support, theta[support], base_pairing, it)

    def free(f: SparseFit) -> int:  # residuals less the shapes' scales, the global scale, the members
        return obs.n_residuals - obs.n_shape_modes - 1 - len(f.members)

    def dispersion(f: SparseFit) -> float:  # as evidence.py's, at this point
        return max(1.0, f.chi2 / max(free(f), 1))

    def score(f: SparseFit, d: float) -> float:
        return -f.chi2 / (2 * d) + f.log_occam(d)

    def determined(f: SparseFit) -> bool:  # at least one degree of freedom left, J^T J regular
        return free(f) >= 1 and np.isfinite(f.log_occam(1.0))

    while len(best.members) > 1:
        # the removal that promises most, judged to second order (chi^2 rises by theta_j^2 / C_jj,
        # C = (J^T J)^-1; the others shift by the regression on j), then refitted and accepted
        # only if the refit's evidence is higher; while the data cannot determine the members kept
        # (more members than data, a singular J^T J: 7 members fitted 5 frequencies exactly) the
        # removal is made whatever the evidence
        k = len(best.members)
        d = dispersion(best)
        cov = np.linalg.pinv(best.jacobian.T @ best.jacobian)
        promise = []
        for j in range(k):
            rest = np.delete(np.arange(k), j)
            shifted = best.theta[rest] - cov[rest, j] * best.theta[j] / cov[j, j] if cov[j, j] > 0 else best.theta[rest]
            wald = best.theta[j] ** 2 / cov[j, j] if cov[j, j] > 0 else 0.0
            promise.append((-(best.chi2 + wald) / (2 * d) + log_occam(shifted, best.jacobian[:, rest], n, d,
                                                                        *sided(shifted)), -wald))
        j = max(range(k), key=lambda i: promise[i])
        rest = np.delete(np.arange(k), j)
        trial = refit(am, obs, support[rest], best.theta[rest], base_pairing, it)
        if determined(best) and score(trial, d) <= score(best, d):
            break
        best, support = trial, support[rest]
    return best if determined(best) else None


def refit(am: _AllMembers, obs: Observations, support: np.ndarray, start: np.ndarray, pairing, iterations: int = 0
          ) -> SparseFit:
    """Bounded nonlinear least squares of the parameters `support` (the rest nominal), from `start`,
    with the modes paired by `pairing`; when the fit, paired afresh, pairs the measured modes
    otherwise, fitted again from there with that pairing (at most `REPAIRS` times): a change that
    moves two close modes past each other (one column line softer, another stiffer) is not
    reached with the pairing of the model it starts from. The pass of lowest chi^2 (paired
    afresh) is kept, not the last: the passes stop when chi^2 does not fall, when a pairing comes
    back, or when the new pairing leaves a measured mode unpaired that the last one paired (fitted
    without that mode, the parameters run off: chi^2 72.3 -> 27,024 -> 467 on the column-line
    frame's held-out refit, tests/test_diagnosis_spread.py)."""
    n = len(am.names)

    def full(x):
        theta = np.zeros(n)
        theta[support] = x
        return theta

    x = np.clip(start, LOW + 1e-9, HIGH - 1e-9)
    pairing = np.asarray(pairing)
    tried, kept = [pairing], None
    for _ in range(1 + REPAIRS):
        def fun(x, pairing=pairing):
            return am.residuals(obs, full(x)[None], pairing)[0].residuals

        def jac(x, pairing=pairing):
            return am.jacobian(obs, full(x), support, pairing)[1]

        x = least_squares(fun, x, jac=jac, bounds=(LOW, HIGH), x_scale=0.1, max_nfev=50).x
        fresh = am.residuals(obs, full(x)[None])[0]  # paired afresh, as every class's chi^2
        if kept is not None and not fresh.chi2 < kept[0].chi2:
            break
        kept = (fresh, x.copy())
        new = np.asarray(fresh.pairing)
        if any(np.array_equal(new, p) for p in tried) or np.sum(new < 0) > np.sum(pairing < 0):
            break
        tried.append(new)
        pairing = new
        x = np.clip(x, LOW + 1e-9, HIGH - 1e-9)
    best, x = kept
    r, j = am.jacobian(obs, full(x), support, best.pairing)
    jtj = j.T @ j
    std = np.sqrt(np.maximum(np.diag(np.linalg.pinv(jtj)), 0.0))  # at D = 1; scaled below
    return SparseFit(tuple(am.names[i] for i in support), x, std, best.chi2, best.s, iterations, n, j,
                     float(math.log(math.comb(n, len(support)))))


def chi2_function(st: Setting, obs: Observations, sf: SparseFit, am: _AllMembers | None = None):
    """chi^2 (paired afresh) of the class at its members' relative changes theta (k,), the rest
    nominal: the likelihood nested sampling integrates (nested.py). am: the class's parameters
    (default every member)."""
    am = _AllMembers(st) if am is None else am
    support = np.array([am.names.index(e) for e in sf.members])

    def chi2_at(x):
        theta = np.zeros(len(am.names))
        theta[support] = x
        return am.residuals(obs, theta[None])[0].chi2

    return chi2_at


def with_dispersion(sf: SparseFit, dispersion: float) -> SparseFit:
    """The fit with its stds at the dispersion D (sqrt(D) x those at D = 1)."""
    from dataclasses import replace

    return replace(sf, theta_std=sf.theta_std * np.sqrt(dispersion))


def held_out(st: Setting, data, used: np.ndarray, sf: SparseFit, freq_noise: float, shape_noise: float,
             am: _AllMembers | None = None):
    """The held-out modes (the highest quarter of `used`, as core.gain splits them) predicted by
    the class refitted, same members, on the other modes: (their correlation, the refit's
    estimate), or None when too few modes to hold any out. am: the class's parameters (default
    every member)."""
    n_hold = max(1, int(round(len(used) / 4)))
    if len(used) - n_hold < 2:
        return None
    obs_fit = Observations.of(data, modes=used[:-n_hold], freq_noise=freq_noise, shape_noise=shape_noise)
    obs_hold = Observations.of(data, modes=used[-n_hold:], freq_noise=freq_noise, shape_noise=shape_noise)
    am = _AllMembers(st) if am is None else am
    support = np.array([am.names.index(e) for e in sf.members])
    base = am.residuals(obs_fit, np.zeros((1, len(am.names))))[0]
    f = refit(am, obs_fit, support, sf.theta, base.pairing)
    theta = np.zeros(len(am.names))
    theta[support] = f.theta
    hz, sh = am.modes(theta[None])
    return correlate(hz[0] * np.sqrt(f.s), sh[0], obs_hold), f.estimate()


def held_out_error(st: Setting, data, used: np.ndarray, sf: SparseFit, freq_noise: float,
                   shape_noise: float, am: _AllMembers | None = None) -> float | None:
    """Mean |frequency error| (%) on the held-out modes of the class refitted without them
    (`held_out`); am: the class's parameters (default every member)."""
    out = held_out(st, data, used, sf, freq_noise, shape_noise, am)
    return None if out is None else out[0].mean_abs_error_pct
