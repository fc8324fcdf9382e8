"""Model-class selection by evidence: each class's marginal likelihood, Laplace at the fitted optimum.

The likelihood-ratio test answers "is there anything at all" against the calibrated model; it
does not charge for parameters between non-nested classes (one local cause, several, a pattern
over many members). The evidence does: Z = integral of L(a) p(a) da, with L = exp(-chi^2 / (2 D))
(chi^2 with the global scale profiled out, which every class shares; D the quasi-likelihood
dispersion, max(1, the best class's reduced chi^2), the same for every class) and the prior of
each effect size uniform on its candidate's range [0, upper].

Laplace: chi^2(a) ~ chi^2(a^) + c (a - a^)^2 / 2 about the fitted optimum (c from a central second
difference), so with sigma^2 = 2 D / c

    log Z = -chi^2(a^) / (2 D) + log(sigma sqrt(2 pi) [Phi((upper - a^)/sigma) - Phi(-a^/sigma)] / upper),

the Gaussian truncated to the prior's range (an optimum at a = 0 keeps half of it). The
calibrated model (no effect) has log Z = -chi^2_0 / (2 D); every log Z is reported relative to it
(a log Bayes factor). A model with several causes uses the curvature of each cause's size with the
others held at theirs (the Hessian's diagonal: by Hadamard's inequality this never overstates the
evidence of the several-cause model). A class whose log evidence is within ln 10 = 2.3 of the best
is "within a factor of 10": the data do not prefer the best strongly over it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.stats import norm

from .key import CandidateKey

#: The next class within this log-evidence difference: within a factor of 10 of the best.
FACTOR_10 = float(np.log(10.0))


def occam_log_factor(chi2_at, a_hat: float, upper: float, dispersion: float = 1.0) -> float:
    """log of integral_0^upper exp(-(chi^2(a) - chi^2(a^)) / (2 D)) da / upper, Laplace at a^.

    chi2_at: sizes (b,) -> chi^2 (b,), one batched call."""
    h = max(1e-3 * upper, 0.02 * abs(a_hat))
    if a_hat - h >= 0.0:
        pts = np.array([a_hat - h, a_hat, a_hat + h])
    else:  # at (or next to) the bound: a one-sided second difference
        pts = np.array([a_hat, a_hat + h, a_hat + 2 * h])
    c = np.asarray(chi2_at(pts), dtype=float)
    curvature = (c[0] - 2 * c[1] + c[2]) / (h * h)   # d^2 chi^2 / da^2
    if not np.isfinite(curvature) or curvature <= 0:
        curvature = 1e-12 / max(upper, 1e-300) ** 2  # flat: the data say nothing about a
    sigma = float(np.sqrt(2.0 * dispersion / curvature))
    mass = norm.cdf((upper - a_hat) / sigma) - norm.cdf(-a_hat / sigma)
    return float(np.log(max(sigma * np.sqrt(2 * np.pi) * mass, 1e-300)) - np.log(upper)) if sigma < 1e150 else 0.0


@dataclass(frozen=True)
class ScoredClass:
    """One model class in the evidence table: its label, family (``none``, ``local``,
    ``distributed``, ``sparse``, ``model_form``, ``several``), number of effect parameters (the
    global scale, shared by all, not counted), chi^2, log evidence relative to the calibrated
    model, the estimate, the mean |frequency error| (%) it predicts on the held-out modes when
    refitted without them, and how its log evidence was found (``laplace``; ``nested``, with
    dynesty's error estimate; ``exact`` for the calibrated model under nested sampling); `keys`:
    the keys of the candidates the class is made of (one; several causes' each; none for a class
    over many members or the calibrated model), not part of the record (its label is)."""

    label: str
    family: str
    n_parameters: int
    chi2: float
    log_evidence: float
    estimate: dict | None = None
    held_out_error_pct: float | None = None
    log_evidence_error: float | None = None
    method: str = "laplace"
    keys: tuple[CandidateKey, ...] = field(default=(), compare=False, repr=False)

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__ if k != "keys"}


@dataclass(frozen=True)
class Evidence:
    """The ranked classes (best first), the method (``laplace``; ``nested``: the best classes by
    Laplace sampled with dynesty, nested.py, each row saying how it was scored), the dispersion
    used, and the note when the next class is within a factor of 10 of the best; predictive: when
    no class fits within the noise, the leave-one-mode-out predictions of the classes scored
    (predictive.py, each `Prediction.to_dict()`), else empty (and not in the JSON)."""

    method: str
    dispersion: float
    classes: tuple[ScoredClass, ...]
    note: str | None = None
    predictive: tuple = ()

    @property
    def best(self) -> ScoredClass | None:
        return self.classes[0] if self.classes else None

    def to_dict(self) -> dict:
        out = {"method": self.method, "dispersion": self.dispersion, "classes": [c.to_dict() for c in self.classes],
               "note": self.note}
        return out | ({"predictive": list(self.predictive)} if self.predictive else {})


def ranked(classes: list[ScoredClass], method: str, dispersion: float) -> Evidence:
    """The classes best first, with the factor-of-10 note."""
    order = sorted(classes, key=lambda c: -c.log_evidence)
    note = None
    if len(order) > 1 and order[0].log_evidence - order[1].log_evidence < FACTOR_10:
        note = (f"the next class, {order[1].label}, is within a factor of 10 of the best, {order[0].label} "
                f"(log evidence {order[1].log_evidence:.3g} against {order[0].log_evidence:.3g}, difference "
                f"< {FACTOR_10:.1f}): the data do not prefer the best strongly")
    return Evidence(method, dispersion, tuple(order), note)


def sides_log_prior(k: int) -> float:
    """log of the prior weight of the sides a class of k members' changes picks from its fit (each
    a loss or a gain, `sparse_class.sided`): -k log 2, as a local stiffness change's side."""
    return -k * float(np.log(2.0))
