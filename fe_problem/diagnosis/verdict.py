"""How good the answer is: the final model's goodness of fit against the stated noise, and a
profile-likelihood interval for each estimate.

Goodness of fit: under the noise model the weighted residuals of a right model are standard
normal, so chi^2 of the final model follows chi^2 with dof = residuals - one per measured
shape (its scale is free) - fitted parameters. p = P(chi^2_dof >= chi^2); below `alpha` the
final model leaves more misfit than the noise explains: an effect outside the candidate set,
a model-form error, or understated noise.

Interval: the effect sizes a whose chi^2 (the global scale profiled, other causes fixed) lies
within dispersion * chi^2_1(level) of the best, found by root-finding on each side.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq
from scipy.stats import chi2 as chi2_dist

from .setting import Candidate
from .fit import Fit, chi2_batch
from .record import Verdict
from .residuals import Observations

LEVEL = 0.95


def verdict(obs: Observations, final: Fit, n_params: int, alpha: float, what: str = "the best explanation") -> Verdict:
    """Test the final model's chi^2 (`final`, with `n_params` fitted parameters incl. the global
    scale) against the noise in `obs`."""
    dof = obs.dof(n_params)
    p = float(chi2_dist.sf(final.chi2, dof))
    reduced = final.chi2 / dof
    r = final.residuals
    n_f = obs.n_frequency_residuals
    implied_f = obs.freq_noise * float(np.sqrt(np.sum(r[:n_f] ** 2) / max(n_f - n_params, 1)))
    n_sh = r.size - n_f
    implied_s = (obs.shape_noise * float(np.sqrt(np.sum(r[n_f:] ** 2) / max(n_sh - obs.n_shape_modes, 1)))
                 if n_sh else None)
    adequate = p >= alpha
    if adequate:
        text = (f"{what} fits within the stated noise (reduced chi^2 {reduced:.2f} over {dof} degrees "
                f"of freedom, p = {p:.3g})")
    else:
        text = (f"{what} still leaves more misfit than the stated noise (reduced chi^2 "
                f"{reduced:.2f} over {dof} degrees of freedom, p = {p:.3g}): an effect outside the candidate "
                "set, a further effect too small to test, or understated noise")
    return Verdict(adequate, final.chi2, dof, reduced, p, alpha, implied_f, implied_s, text)


def profile_interval(obs: Observations, cand: Candidate, best: Fit, dispersion: float,
                     level: float = LEVEL) -> tuple[float | None, float | None]:
    """The effect sizes (low, high) where chi^2 rises by dispersion * chi^2_1(level) above the
    best; None on a side where the candidate's range ends first (0 is a valid low end: then 0)."""
    rise = dispersion * float(chi2_dist.isf(1.0 - level, 1))
    target = best.chi2 + rise

    def g(v: float) -> float:
        return chi2_batch(obs, cand, np.array([v]))[0].chi2 - target

    lo_end, hi_end = 0.0, cand.upper
    low = 0.0 if g(lo_end) <= 0 else _root(g, lo_end, best.a)
    high = None if g(hi_end) <= 0 else _root(g, best.a, hi_end)
    return low, high


def _root(g, a: float, b: float) -> float | None:
    try:
        return float(brentq(g, a, b, xtol=1e-4 * max(abs(b), 1e-9), maxiter=40))
    except ValueError:  # no sign change: the pairing jumped; no interval on that side
        return None


def interval_of(cand: Candidate, low: float | None, high: float | None, s: float, level: float = LEVEL) -> dict:
    """The interval in the estimate's own terms: every numeric estimate at both ends, sorted."""
    out: dict = {"level": level}
    ends = [cand.estimate(v, s) if v is not None else None for v in (low, high)]
    keys = [k for k, v in cand.estimate(0.5 * cand.upper, s).items() if isinstance(v, (int, float))]
    for key in keys:
        vals = [None if e is None else e[key] for e in ends]
        finite = [v for v in vals if v is not None and np.isfinite(v)]
        if len(finite) == 2:
            out[key] = sorted(finite)
        else:
            out[key] = vals
    return out
