"""A class's evidence by nested sampling (dynesty): the check of the Laplace approximation.

The quantity is the one evidence.py approximates at the fitted optimum: with the prior uniform on
the class's box [lower, upper]^k of volume V,

    log Z = log( integral exp(-(chi^2(a) - chi^2_ref) / (2 D)) da / V ),

chi^2_ref the calibrated model's (so log Z is a log Bayes factor against it) and D the dispersion
every class shares. dynesty (Speagle 2020; static nested sampling, `NLIVE` live points, run until
the remaining evidence is below `DLOGZ`; uniform sampling in one bounding ellipsoid) gives log Z
and its error estimate. Each class's sampler
is seeded from `SEED` and the class's label (crc32), so a diagnosis gives the same numbers in any
process and in any order of the classes. dynesty is an optional dependency (`.[nested]`).
"""

from __future__ import annotations

import dataclasses
import zlib
from typing import Callable

import numpy as np

from .evidence import Evidence, ranked

#: Live points, and the stopping criterion (the remaining evidence's log bound).
NLIVE, DLOGZ = 100, 0.05
#: The first bounding ellipsoid after NLIVE calls, or once fewer than half the proposals from the
#: unit cube are accepted (dynesty's default waits for 2 NLIVE calls and 10 %: on a posterior a
#: twentieth of its prior's width, 4,190 likelihood calls where this takes 1,016).
FIRST_UPDATE = {"min_ncall": NLIVE, "min_eff": 50.0}
#: The base seed of every class's sampler.
SEED = 2026
#: How many classes, the best by Laplace, are sampled (a class costs about a thousand solves):
#: those the text's table shows.
N_NESTED = 6


def require_dynesty():
    """The dynesty module, or a ValueError saying how to install it."""
    try:
        import dynesty
    except ImportError:
        raise ValueError("evidence 'nested' needs the optional dependency dynesty: "
                         "pip install \"femu-bench[nested]\" (or pip install dynesty)") from None
    return dynesty


def seed_of(label: str) -> int:
    """The sampler's seed of a class: `SEED` and its label, independent of the process and order."""
    return int(np.random.SeedSequence([SEED, zlib.crc32(label.encode())]).generate_state(1)[0])


def log_evidence(chi2_at: Callable[[np.ndarray], float], lower, upper, chi2_ref: float, dispersion: float,
                 seed: int, nlive: int = NLIVE, dlogz: float = DLOGZ) -> tuple[float, float, int]:
    """(log Z, its dynesty error, likelihood calls) of the class whose chi^2 at parameters a (k,)
    is `chi2_at(a)`, prior uniform on the box [lower, upper] (see the module docstring)."""
    dynesty = require_dynesty()
    lower, upper = np.atleast_1d(np.asarray(lower, float)), np.atleast_1d(np.asarray(upper, float))
    span = upper - lower

    def loglike(a):
        c = chi2_at(a)
        return -(c - chi2_ref) / (2.0 * dispersion) if np.isfinite(c) else -1e300

    def prior_transform(u):
        return lower + u * span

    sampler = dynesty.NestedSampler(loglike, prior_transform, len(lower), nlive=nlive, bound="single",
                                    sample="unif", first_update=dict(FIRST_UPDATE, min_ncall=nlive),
                                    rstate=np.random.default_rng(seed))
    sampler.run_nested(dlogz=dlogz, print_progress=False)
    res = sampler.results
    return float(res.logz[-1]), float(res.logzerr[-1]), int(np.sum(res.ncall))


def rescored(ev: Evidence, classes: dict, chi2_ref: float, dispersion: float, n_nested: int = N_NESTED) -> Evidence:
    """The Laplace-ranked table `ev` with the best `n_nested` classes that have a chi^2 function in
    `classes` (label -> (chi2_at, lower, upper, log_offset); log_offset is added to log Z, e.g. the
    sparse class's -log C(n, k)) scored by nested sampling instead, then ranked again. The
    calibrated model keeps log Z = 0 exactly (no parameter); every other class keeps its Laplace
    value, its row saying so (`method`)."""
    require_dynesty()
    out = []
    k = 0
    for c in ev.classes:
        if c.label in classes and k < n_nested:
            k += 1
            chi2_at, lower, upper, offset = classes[c.label]
            lz, err, _ = log_evidence(chi2_at, lower, upper, chi2_ref, dispersion, seed_of(c.label))
            c = dataclasses.replace(c, log_evidence=lz + offset, log_evidence_error=err, method="nested")
        elif c.family == "none":
            c = dataclasses.replace(c, log_evidence_error=0.0, method="exact")
        out.append(c)
    return ranked(out, "nested", dispersion)
