"""What an estimate of the updating parameters is worth: 95 % intervals, identifiability,
correlations, bounds reached, and the misfit against the measured noise (`femu update`).

At the estimate x the balanced objective's noise residuals e_k (frequencies, shapes; in units
of their stated standard deviations, `UpdatingProblem.noise_residuals`) and their Jacobians
G_k give each kind's error scale s_k^2 = max(1, R_k / n_k) (R_k = |e_k|^2 over n_k entries:
the same scale the objective profiles out) and the Fisher information
F = sum_k G_k^T G_k / s_k^2. Its inverse is the covariance of x (linearised, Gaussian errors);
the 95 % interval is x +- 1.96 sqrt(diag), null where F is singular in that parameter's
direction or the interval is wider than the parameter's range (the data do not pin it down).
The verdict compares chi^2 = sum_k R_k (with the stated noise, no scale) with its distribution
on N - p degrees of freedom.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The two-sided 95 % normal quantile.
Z95 = 1.959963984540054
#: Singular values of the scaled Fisher matrix below this fraction of the largest are zero.
RANK_TOL = 1e-10
#: The chi^2 test's level: a misfit less likely than this under the stated noise is beyond it.
FIT_LEVEL = 0.01
KINDS = ("frequencies", "shapes")


@dataclass(frozen=True, eq=False)
class Estimate:
    """The statistics of an estimate x (n,) of a problem's parameters.

    interval_95 (n, 2), NaN where not identifiable; identifiable, at_bound (n,) bool;
    std (n,) (NaN where not identifiable); correlation (n, n) (NaN rows where not identifiable);
    covariance (n, n) in the parameters' units (NaN rows and columns where not identifiable);
    per kind (`KINDS`, a kind without entries left out): chi2, n, scale (s_k = sqrt(max(1,
    chi2 / n))); chi2_total, dof = N - p, reduced_chi2 = chi2_total / dof (NaN when dof < 1),
    p_value of chi2_total under the stated noise, fits_noise = p_value >= FIT_LEVEL."""

    x: np.ndarray
    interval_95: np.ndarray
    identifiable: np.ndarray
    at_bound: np.ndarray
    std: np.ndarray
    correlation: np.ndarray
    covariance: np.ndarray
    chi2: dict
    n: dict
    scale: dict
    chi2_total: float
    dof: int
    reduced_chi2: float
    p_value: float
    fits_noise: bool


def estimate_of(problem, x) -> Estimate:
    """The statistics of the estimate x of a balanced `UpdatingProblem` (module docstring)."""
    from scipy.stats import chi2 as chi2_dist

    if problem.objective != "balanced":
        raise ValueError("estimate_of needs an UpdatingProblem with objective='balanced'")
    x = problem.check_x(x, "x")[0]
    e_f, e_s, g_f, g_s = problem.noise_jacobian(x)
    chi2, n, scale = {}, {}, {}
    fisher = np.zeros((problem.n_var, problem.n_var))
    span = problem.xu - problem.xl
    for kind, e, g in (("frequencies", e_f, g_f), ("shapes", e_s, g_s)):
        if not e.size:
            continue
        chi2[kind], n[kind] = float(e @ e), int(e.size)
        scale[kind] = float(np.sqrt(max(1.0, chi2[kind] / n[kind])))
        gu = g * span  # in units of each parameter's range: the same conditioning for Pa and kg
        fisher += gu.T @ gu / scale[kind] ** 2
    u, sv, vt = np.linalg.svd(fisher)
    keep = sv > RANK_TOL * sv[0] if sv[0] > 0 else np.zeros_like(sv, dtype=bool)
    null = vt[~keep]
    cov_u = (vt[keep].T / sv[keep]) @ vt[keep]
    std = np.sqrt(np.maximum(np.diag(cov_u), 0.0)) * span
    identifiable = ~(np.abs(null) > 1e-6).any(axis=0) & (Z95 * std <= span)
    std = np.where(identifiable, std, np.nan)
    interval = np.where(identifiable[:, None], x[:, None] + np.array([-Z95, Z95])[None] * std[:, None], np.nan)
    d = np.sqrt(np.maximum(np.diag(cov_u), 1e-300))
    corr = cov_u / np.outer(d, d)
    corr[~identifiable] = np.nan
    corr[:, ~identifiable] = np.nan
    cov = cov_u * np.outer(span, span)
    cov[~identifiable] = np.nan
    cov[:, ~identifiable] = np.nan
    tol = 1e-6 * span
    at_bound = (x <= problem.xl + tol) | (x >= problem.xu - tol)
    total = float(sum(chi2.values()))
    dof = int(sum(n.values())) - problem.n_var
    reduced = total / dof if dof >= 1 else float("nan")
    p_value = float(chi2_dist.sf(total, dof)) if dof >= 1 else float("nan")
    return Estimate(x, interval, identifiable, at_bound, std, corr, cov, chi2, n, scale, total, dof, reduced, p_value,
                    bool(dof >= 1 and p_value >= FIT_LEVEL))


def frequency_ranges(problem, est: Estimate, n_modes: int) -> np.ndarray:
    """The 95 % range (n_modes, 2) of the model's first `n_modes` frequencies (Hz) at the
    estimate: f +- 1.96 sqrt(g^T C g), g the frequency's sensitivities, C the estimate's
    covariance (linearised); NaN where a parameter is not identifiable."""
    lam, _, dlam = problem.system.eigen_sensitivities(est.x[None], n_modes, rows=problem.rows)
    from .modal import frequencies_hz

    f = frequencies_hz(lam[0])
    g = dlam[0] / (8.0 * np.pi**2 * f[:, None])                 # (n_modes, n_var) Hz per unit
    sd = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", g, est.covariance, g), 0.0))
    return np.column_stack([f - Z95 * sd, f + Z95 * sd])


__all__ = ["Estimate", "FIT_LEVEL", "KINDS", "Z95", "estimate_of", "frequency_ranges"]
