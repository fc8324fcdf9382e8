"""Which class predicts: leave-one-mode-out prediction of each model class, used when nothing fits.

When no class fits within the stated noise (the evidence's dispersion D > 1), the evidence compares
classes none of which is true; a likelihood difference shrunk by D, or a class's charge for its
parameters, can then decide between a one-member class and a pattern that predicts the modes far
better (issue 38). What a class is for is to predict what it was not fitted to, so the choice then
also asks for that (model class selection by predictive performance, Vehtari, Gelman & Gabry 2017,
"Practical Bayesian model evaluation using leave-one-out cross-validation and WAIC", Stat. Comput.
27:1413; in model updating, Beck & Yuen 2004, J. Eng. Mech. 130:192, and Simoen, De Roeck &
Lombaert 2015, Mech. Syst. Signal Process. 56-57:123, on class selection and its model error).

Leave one mode out. For each measured mode m the class (its parameters theta and the global scale,
as `log s`) is refitted without m's residuals (its frequency and its shape entries) and predicts
them. The refit is first order (one Gauss-Newton step from the fit to every mode, the Jacobian J of
the residuals at that fit, the modes' pairing held): with R the other modes' rows,

    delta_m = -(J_R^T J_R)^-1 J_R^T r_R,    predicted r_m = r_m + J_m delta_m,

each parameter kept within its prior's range (a bound hit is held at it and the rest solved again),
the standard first-order approximation of case deletion (Cook's distance; for a linear model it is
exact). A test checks it against exact refits. The predictive density of mode m is Gaussian with
the dispersion D and the refit's own spread, covariance D (I + J_m (J_R^T J_R)^-1 J_m^T), and

    elpd_loo = sum_m log p(r_m | the other modes)

(Vehtari et al.'s expected log predictive density, with its standard error sqrt(M var)). One
batched solve of k + 1 models per class (k its parameters): the modes' refits are linear algebra
on stacked arrays, with no solve per mode.

The rule (`follow`), applied when D > 1 only (when a class fits within the noise nothing changes):

- among the classes whose log evidence is not decisively apart from the answer's (within ln 10, or
  above it), the one with the highest elpd_loo is the answer when it predicts better than the
  answer by more than `MARGIN` and may be an answer here (a non-local class: distributed, sparse,
  model form; a local class other than the local search's own result is not: its rounds chose);
- an answer is not decisive when a class that is a different answer (`answer.same_answer`) and
  whose elpd_loo is computed predicts the held-out modes better than it by more than `MARGIN`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

import numpy as np

from . import sparse_class
from .answer import NONE_LABEL
from .evidence import FACTOR_10
from .fit import profiled
from .residuals import Observations

#: elpd_loo above the answer's by more than this (ln 10: a factor of 10 in predictive density,
#: the evidence's own "decisive") is predicting better.
MARGIN = FACTOR_10
#: The classes of the evidence table (best first) whose elpd_loo is computed, besides the answer.
N_SCORED = 8
#: Relative finite-difference step of the Jacobian (of the range of a parameter).
STEP = 1e-4
#: Relative step of log s (no solve: the frequencies scale with sqrt(s)).
LOG_S_STEP = 1e-6


@dataclass(frozen=True, eq=False)
class ClassModel:
    """A fitted class as the leave-one-mode-out refit needs it: `forward` (theta (b, k) -> the
    modes, frequencies (b, K) Hz and shapes at the measured coordinates (b, n_coord, K)), the fitted
    theta (k,) and global scale s, each parameter's prior range (lower, upper) and the modes' pairing
    at the fit (measured mode -> model mode)."""

    label: str
    forward: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    theta: np.ndarray
    s: float
    lower: np.ndarray
    upper: np.ndarray
    pairing: np.ndarray


def of_candidate(cand, f) -> ClassModel:
    """A one-parameter class (a `candidates.Candidate` and its `fit.Fit`)."""
    return ClassModel(cand.label, lambda t: cand.forward(np.asarray(t, float)[:, 0]), np.array([f.a]), f.s,
                      np.array([0.0]), np.array([float(cand.upper)]), np.asarray(f.pairing))


def of_moduli(label: str, am, sf, obs: Observations) -> ClassModel:
    """A class of member moduli (`sparse_class._AllMembers` `am`, its `SparseFit` `sf`: the sparse
    class, a free group class), its members' changes free within [LOW, HIGH]."""
    low, high = sparse_class.LOW, sparse_class.HIGH
    support = np.array([am.names.index(e) for e in sf.members])

    def forward(t):
        full = np.zeros((len(t), len(am.names)))
        full[:, support] = t
        return am.modes(full)

    theta = np.asarray(sf.theta, float)
    hz, sh = forward(theta[None])
    pairing = profiled(obs, hz[0], sh[0]).pairing
    return ClassModel(label, forward, theta, sf.s, np.full(len(theta), low), np.full(len(theta), high), pairing)


def of_calibrated(label: str, hz0: np.ndarray, sh0: np.ndarray, base) -> ClassModel:
    """The calibrated model (no effect): the global scale its only parameter."""
    return ClassModel(label, lambda t: (np.repeat(hz0[None], len(t), 0), np.repeat(sh0[None], len(t), 0)),
                      np.zeros(0), base.s, np.zeros(0), np.zeros(0), np.asarray(base.pairing))


@dataclass(frozen=True)
class Prediction:
    """One class's leave-one-mode-out prediction: elpd_loo (log predictive density of every mode's
    residuals given the others, summed), its standard error, each mode's term, each mode's predicted
    frequency error (%, model against measured, signed) and the mean |frequency error| (%)."""

    label: str
    elpd_loo: float
    elpd_se: float
    elpd_modes: tuple[float, ...]
    frequency_error_pct: tuple[float, ...]
    mean_abs_error_pct: float

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def mode_rows(obs: Observations) -> np.ndarray:
    """(M, L) the rows of each measured mode in the residual vector (`Observations.residuals_paired`:
    the frequencies first, then each shaped mode's coordinates), padded with -1 to the longest."""
    m, n_coord = obs.n_modes, obs.shapes.shape[0]
    rank = np.cumsum(obs.has_shape) - 1
    rows = np.full((m, 1 + n_coord), -1, dtype=int)
    rows[:, 0] = np.arange(m)
    shaped = np.flatnonzero(obs.has_shape)
    rows[shaped, 1:] = m + rank[shaped, None] * n_coord + np.arange(n_coord)[None, :]
    return rows


def linearised(obs: Observations, cm: ClassModel) -> tuple[np.ndarray, np.ndarray]:
    """The residuals r (n,) at the fit and their Jacobian J (n, k + 1) over theta and log s: one
    batched solve of the fit and k forward steps, the pairing held."""
    k = len(cm.theta)
    h = STEP * np.maximum(cm.upper - cm.lower, 1e-12)
    # a step inward from a bound (a forward difference either way)
    sign = np.where(cm.theta + h <= cm.upper, 1.0, -1.0)
    batch = np.repeat(cm.theta[None], k + 1, axis=0)
    batch[1 + np.arange(k), np.arange(k)] += sign * h
    hz, sh = cm.forward(batch)
    scales = np.array([cm.s] * (k + 1) + [cm.s * np.exp(LOG_S_STEP)])
    hz_all = np.concatenate([hz, hz[:1]]) * np.sqrt(scales)[:, None]
    sh_all = np.concatenate([sh, sh[:1]])
    r = obs.residuals_paired(hz_all, sh_all, cm.pairing)
    jac = np.empty((r.shape[1], k + 1))
    jac[:, :k] = ((r[1:k + 1] - r[0]) / (sign * h)[:, None]).T
    jac[:, k] = (r[k + 1] - r[0]) / LOG_S_STEP
    return r[0], jac


def leave_one_mode_out(obs: Observations, cm: ClassModel, dispersion: float) -> Prediction:
    """The class's first-order leave-one-mode-out prediction (module docstring) at dispersion D."""
    r, jac = linearised(obs, cm)
    rows = mode_rows(obs)
    m = rows.shape[0]
    delta, inv = refit_steps(obs, cm, np.repeat(r[None], m, axis=0), jac, np.zeros((m, jac.shape[1])))
    return scored(obs, cm.label, r, jac, rows, delta, inv, dispersion)


def refit_steps(obs: Observations, cm: ClassModel, r: np.ndarray, jac: np.ndarray, start: np.ndarray):
    """Each mode's refit without it, one Gauss-Newton step with the fit's Jacobian `jac` from `start`
    (M, p) (theta and log s less the fit's; zero: the fit), where the residuals are r (M, n): the
    steps delta (M, p) and the inverse normal matrices (M, p, p) of the free parameters (0 where held
    at a bound). Vectorised over the modes; a parameter past its range is held at the
    bound and the others solved again (twice at most)."""
    rows = mode_rows(obs)
    m, p = rows.shape[0], jac.shape[1]
    rest = np.ones((m, r.shape[1]))
    for i in range(m):
        rest[i, rows[i][rows[i] >= 0]] = 0.0
    a = np.einsum("mi,ij,il->mjl", rest, jac, jac)          # J_R^T J_R per mode
    g = np.einsum("mi,ij,mi->mj", rest, jac, r)             # J_R^T r_R per mode
    lo = np.concatenate([cm.lower - cm.theta, [-np.inf]])[None] - start
    hi = np.concatenate([cm.upper - cm.theta, [np.inf]])[None] - start
    free = np.ones((m, p), dtype=bool)
    fixed = np.zeros((m, p))
    ridge = 1e-12 * np.maximum(np.einsum("mjj->m", a), 1e-300)[:, None, None] * np.eye(p)
    for _ in range(3):
        both = free[:, :, None] & free[:, None, :]
        a_f = np.where(both, a, 0.0) + np.where(~free[:, :, None], np.eye(p)[None], 0.0) + ridge
        rhs = np.where(free, -g - np.einsum("mjl,ml->mj", a, np.where(free, 0.0, fixed)), fixed)
        step = np.linalg.solve(a_f, rhs[..., None])[..., 0]
        past = free & ((step < lo - 1e-15) | (step > hi + 1e-15))
        if not past.any():
            break
        fixed = np.where(past, np.clip(step, lo, hi), fixed)
        free &= ~past
    inv = np.linalg.inv(a_f) * (free[:, :, None] & free[:, None, :])
    return start + step, inv


def scored(obs: Observations, label: str, r: np.ndarray, jac: np.ndarray, rows: np.ndarray, delta: np.ndarray,
           inv: np.ndarray, dispersion: float) -> Prediction:
    """The predictive densities of the modes' residuals, r_m + J_m delta_m, from their refits (`refit_steps`)."""
    valid = rows >= 0
    idx = np.where(valid, rows, 0)
    j_m = jac[idx] * valid[..., None]                           # (M, L, p)
    r_m = (r[idx] + np.einsum("mlp,mp->ml", j_m, delta)) * valid
    cov = np.eye(rows.shape[1])[None] + np.einsum("mlp,mpq,mkq->mlk", j_m, inv, j_m)
    sign, logdet = np.linalg.slogdet(cov)
    quad = np.einsum("ml,ml->m", r_m, np.linalg.solve(cov, r_m[..., None])[..., 0])
    n_m = valid.sum(axis=1)
    elpd = -0.5 * (quad / dispersion + logdet + n_m * np.log(2 * np.pi * dispersion))
    rel = obs.freq_noise if obs.freq_rel_std is None else obs.freq_rel_std
    err = 100.0 * r_m[:, 0] * rel
    m = len(elpd)
    return Prediction(label, float(elpd.sum()), float(np.sqrt(m * np.var(elpd))) if m > 1 else 0.0,
                      tuple(float(x) for x in elpd), tuple(float(x) for x in err), float(np.mean(np.abs(err))))


def follow(ev, predictions: dict, row, runner, decisive: bool, may_answer: Callable, same_answer: Callable):
    """The answer after the predictive rule (module docstring): (row, runner-up, decisive, the
    sentence saying what prediction changed, or None). `predictions`: label -> `Prediction` of the
    classes scored; may_answer(row): whether a class may replace the answer; same_answer(a, b):
    whether two classes are one answer. Applied only when the evidence's dispersion exceeds 1."""
    if ev.dispersion <= 1.0 or row is None or row.label not in predictions:
        return row, runner, decisive, None
    own = predictions[row.label]
    close = [c for c in ev.classes if c.label in predictions and row.log_evidence - c.log_evidence < FACTOR_10
             and not same_answer(c, row) and may_answer(c)]
    best = max(close, key=lambda c: predictions[c.label].elpd_loo, default=None)
    note = None
    if best is not None and predictions[best.label].elpd_loo - own.elpd_loo > MARGIN:
        p = predictions[best.label]
        note = (f"no class fits within the noise (dispersion {ev.dispersion:.3g}); {best.label} predicts each mode "
                f"left out better than {row.label} (leave-one-mode-out elpd {p.elpd_loo:.4g} against "
                f"{own.elpd_loo:.4g}, mean |frequency error| {p.mean_abs_error_pct:.3g} % against "
                f"{own.mean_abs_error_pct:.3g} %) and is not decisively apart from it in evidence "
                f"(log evidence {best.log_evidence:.4g} against {row.log_evidence:.4g}): it is the answer")
        row, runner, own = best, row, p
        decisive = False
    better = [c for c in ev.classes if c.label in predictions and not same_answer(c, row)
              and predictions[c.label].elpd_loo - own.elpd_loo > MARGIN]
    if better and decisive:
        c = max(better, key=lambda c: predictions[c.label].elpd_loo)
        p = predictions[c.label]
        note = (f"no class fits within the noise (dispersion {ev.dispersion:.3g}), and {c.label} predicts each "
                f"mode left out better than the answer (leave-one-mode-out elpd {p.elpd_loo:.4g} against "
                f"{own.elpd_loo:.4g}, mean |frequency error| {p.mean_abs_error_pct:.3g} % against "
                f"{own.mean_abs_error_pct:.3g} %): the answer is not decisive")
        runner, decisive = c, False
    return row, runner, decisive, note


def class_models(cal, scored, labels) -> dict:
    """label -> `ClassModel` of the classes `labels` of the evidence table that have one: the
    calibrated model, every fitted one-parameter class (`Scored.fitted`), the sparse class, the free
    group classes (the local search's several causes have none: left out)."""
    out = {}
    for label in labels:
        if label == NONE_LABEL:
            out[label] = of_calibrated(label, cal.hz0, cal.sh0, cal.base)
        elif label in scored.fitted:
            out[label] = of_candidate(*scored.fitted[label])
        elif scored.sparse is not None and label == scored.sparse.label:
            out[label] = of_moduli(label, sparse_class._AllMembers(cal.setting), scored.sparse, cal.obs)
        elif label in scored.groups:
            g = scored.groups[label]
            out[label] = of_moduli(label, g.params, g.fit, cal.obs)
    return out


def predictions(cal, scored, answer_label: str | None) -> dict:
    """label -> `Prediction` of the answer's class and the `N_SCORED` best of the evidence table (those
    with a `ClassModel`), at the evidence's dispersion; {} when some class fits within the noise
    (dispersion 1: the rule does not apply)."""
    ev = scored.evidence
    if ev.dispersion <= 1.0:
        return {}
    labels = [c.label for c in ev.classes[:N_SCORED]] + ([answer_label] if answer_label else [])
    models = class_models(cal, scored, dict.fromkeys(labels))
    return {label: leave_one_mode_out(cal.obs, cm, ev.dispersion) for label, cm in models.items()}
