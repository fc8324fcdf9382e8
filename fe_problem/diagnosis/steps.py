"""The steps of one round of a diagnosis (core.py's method): calibrate the global stiffness, screen
and fit the candidates, select by the likelihood-ratio test, extend the model by the selected
cause, and the gain on held-out modes. core.py runs them once and the further-cause rounds
(rounds.py, joint.py) again on the model extended by the causes found: both import them from here
(no import inside a function between core and rounds)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import chi2 as chi2_dist

from ..assembly import AffineModel, solver_path
from ..correlation import correlate
from ..modal_data import DataFileError, ModalData
from ..model import FrameModel, ModelFileError
from ..parameters import Parameter
from .candidates import Candidate, Setting, all_candidates, scale_stiffness, solve
from .fit import Fit, brings, chi2_batch, fit, look_along, profiled, promise
from . import dropped
from .record import Cause, CandidateFit, Gain, PinnedParameter, Residuals, Selection
from .verdict import profile_interval
from .residuals import Observations
from .screening import linear_bounded_moduli, screen_all

#: Candidates whose chi^2 lies within this of the best (at the dispersion) cannot be told apart.
AMBIGUITY_CHI2 = 2.0 * np.log(20.0)
#: A diagnosis needs at least this many measured modes.
MIN_MODES = 3
#: How the cause is selected, as the record states it.
METHOD = "likelihood ratio vs the calibrated model, Bonferroni over candidates, quasi-likelihood dispersion"


# == 1. calibrate ===============================================================================
@dataclass(frozen=True, eq=False)
class Calibration:
    """The nominal model with its global scale fitted: what every later step starts from.

    hz0, sh0: the nominal model's frequencies (Hz) and shapes at the measured coordinates;
    base_all: its profiled fit to every measured mode; used / unpaired: measured modes (0-based)
    that pair / pair with no model mode; obs, base: the paired modes and the fit to them."""

    setting: Setting
    data: ModalData
    obs_all: Observations
    obs: Observations
    used: np.ndarray
    unpaired: np.ndarray
    hz0: np.ndarray
    sh0: np.ndarray
    base_all: Fit
    base: Fit
    warnings: tuple[str, ...]


def calibrate(model: FrameModel, data: ModalData, freq_noise: float, shape_noise: float,
              reference: FrameModel | None = None) -> Calibration:
    """Fit the global stiffness-to-mass scale; measured modes that pair with no model mode are
    shown, never fitted. reference: the user's model when `model` is it extended (Setting)."""
    system = AffineModel(model)
    if system.massless.size:
        # its zone batches, reduced bases and adjoint screening assume mass on every free DOF
        raise ModelFileError(f"{model.source or model.name}: {system.massless.size} DOF(s) carry no mass (lumped mass "
                             "without rotary inertia, or a pinned end's rotation): the diagnosis does not handle "
                             "DOFs without mass yet; give the nodes rotary inertia, or import with --mass consistent")
    st = Setting(model, data.dofs, min(data.n_modes + 6, system.n_elastic), reference)
    st.__dict__["system"] = system  # `Setting.system`'s cache: the model's one system
    obs_all = Observations.of(data, freq_noise=freq_noise, shape_noise=shape_noise)
    hz, sh = st.modes0
    hz0, sh0 = hz[0], sh[0]
    base_all = profiled(obs_all, hz0, sh0)
    unpaired = np.flatnonzero(base_all.pairing < 0)
    used = np.flatnonzero(base_all.pairing >= 0)
    warnings = []
    if len(unpaired):
        warnings.append(f"measured mode(s) {[int(i) + 1 for i in unpaired]} pair with no model mode "
                        "(MAC < 0.5 with every model mode, or no model frequency within 30 %): left out of the fit")
    if len(used) < MIN_MODES:
        raise DataFileError(f"{data.source}: only {len(used)} measured mode(s) pair with a mode of model "
                            f"{model.name!r}; a diagnosis needs at least {MIN_MODES}")
    if not obs_all.has_shape[used].any():
        warnings.append("no measured shapes: frequencies alone can rarely tell a place apart")
    obs = Observations.of(data, modes=used, freq_noise=freq_noise, shape_noise=shape_noise)
    return Calibration(st, data, obs_all, obs, used, unpaired, hz0, sh0, base_all, profiled(obs, hz0, sh0),
                       tuple(warnings))


def residuals_of(cal: Calibration) -> Residuals:
    """What the calibrated model gets wrong: the correlation of every measured mode, chi^2, and
    the moduli a bounded update pins at a bound."""
    base = cal.base
    return Residuals(correlate(cal.hz0 * np.sqrt(base.s), cal.sh0, cal.obs_all, cal.base_all.pairing),
                     base.s, base.chi2, cal.obs.n_residuals, base.chi2 / cal.obs.dof(1),
                     tuple(int(i) + 1 for i in cal.unpaired),
                     dropped.guarded("the bounded modulus update (pinned moduli)", lambda: _pinned_moduli(cal), ()),
                     tuple((int(n), str(d)) for n, d in cal.data.dofs))


def _pinned_moduli(cal: Calibration) -> tuple[PinnedParameter, ...]:
    """Element moduli a bounded update (+-1/7 of the calibrated value) drives to a bound.

    Where a solve is cheap (the dense path) the update is a nonlinear least-squares fit; on a
    larger model (hundreds of moduli, a finite-difference Jacobian of as many solves) it is
    linearised at the calibrated model from one set of first-order modes and fitted as the MAP
    with each box a Gaussian prior of its width (screening.bounded_linear_fit: unique and
    continuous in the data, so the list is set by the data, not by rounding)."""
    st, obs = cal.setting, cal.obs
    e_nom = np.array([st.model.element_modulus_pa(e) for e in st.model.element_ids])
    params = tuple(Parameter("modulus", (e,), 1e-3 * v, 1e3 * v, v, name=f"E{e}")
                   for e, v in zip(st.model.element_ids, e_nom))
    e0 = e_nom * cal.base.s
    lo, hi = e0 * 6.0 / 7.0, e0 * 8.0 / 7.0
    if solver_path(len(st.local.dofmap.free), "auto", len(params)) == "dense":
        system = AffineModel(st.model, params)

        def residuals(z):  # z in [0, 1]^n: the moduli scaled into their bounds
            hz, sh = solve(system, (lo + z * (hi - lo))[None], st.coords, st.n_modes)
            return obs.residuals(hz[0], sh[0], cal.base.pairing)[0]

        z_best = least_squares(residuals, np.full(len(params), 0.5), bounds=(0.0, 1.0), diff_step=1e-4,
                               max_nfev=60).x
    else:
        z_best = linear_bounded_moduli(obs, cal.base, st.local, st.coords, st.n_modes, 6.0 / 7.0, 8.0 / 7.0)
    return tuple(PinnedParameter(p.label, p.targets[0], "lower" if z <= 0.005 else "upper",
                                 float(lo[k] + z * (hi - lo)[k]))
                 for k, (p, z) in enumerate(zip(params, z_best)) if z <= 0.005 or z >= 0.995)


# == 2. screen and fit ==========================================================================
@dataclass(frozen=True, eq=False)
class Screening:
    """Every candidate with its first-order (chi^2 drop, effect size), the screening order
    (largest drop first) and the proper fits of the most promising (index -> Fit)."""

    candidates: list[Candidate]
    screened: list[tuple[float, float]]
    order: list[int]
    fitted: dict[int, Fit]


def screen_and_fit(cal: Calibration, kinds, n_fit: int | None, keep=None, bring=None) -> Screening:
    """Screen every candidate (those `keep` accepts) by its first-order chi^2 drop; fit the
    `n_fit` most promising (None: all), and always the global candidates (no place: a
    first-order screen misjudges them, being far from linear) and the two best screened
    of every kind (a kind is never judged by another's linearisation); `bring`: measured modes
    (indices into `cal.obs`) the calibrated model leaves unpaired, and every candidate that
    pairs one of them at some size of its grid is fitted too (`fit.brings`)."""
    cands = [c for c in all_candidates(cal.setting, kinds) if keep is None or keep(c)]
    screened = look_at_clipped(cal, cands, screen_candidates(cal, cands), n_fit)
    # a candidate whose solve failed (dropped.py) is neither ranked nor fitted
    screened = [(0.0, 0.0) if dropped.is_dropped(c.label) else x for c, x in zip(cands, screened)]
    order, chosen = to_fit(cands, screened, n_fit)
    if bring is not None and len(bring):
        chosen |= {i for i in order if i not in chosen and brings(cal.obs, cands[i], bring)}
    chosen = {i for i in chosen if not dropped.is_dropped(cands[i].label)}
    fitted = {i: fit(cal.obs, cands[i], screened[i][1]) for i in order if i in chosen}
    fitted = {i: f for i, f in fitted.items() if not dropped.is_dropped(cands[i].label)}  # failed in its fit
    order = [i for i in order if i in fitted] + [i for i in order if i not in fitted]
    return Screening(cands, screened, order, fitted)


def to_fit(cands: list[Candidate], screened: list[tuple[float, float]], n_fit: int | None) -> tuple[list[int], set[int]]:
    """The screening order (largest first-order drop first) and the candidates to fit: the
    `n_fit` first (None: all), every global one, and the two first of every kind."""
    order = sorted(range(len(cands)), key=lambda i: -screened[i][0])
    chosen = set(order if n_fit is None else order[:n_fit])
    chosen |= {i for i in order if cands[i].location is None}
    for kind in {c.kind for c in cands}:
        chosen |= set([i for i in order if cands[i].kind == kind][:2])
    return order, chosen


def screen_candidates(cal: Calibration, cands: list[Candidate]) -> list[tuple[float, float]]:
    """Every candidate's screened (chi^2 drop, a). Where a solve is cheap (the model takes the
    dense path) each candidate is screened by one exact step and a look at a few sizes of its
    grid (`fit.screen`, `fit.look_along`); on a larger model, to first order from one set of modes and each
    candidate's first-order term (screening.py), so no candidate builds or solves its own
    system; a candidate without a term (a global effect) is screened as on the dense path."""
    st = cal.setting
    if solver_path(len(st.local.dofmap.free)) == "dense" or not cands:
        return [_screen_solved(cal, c) for c in cands]
    first = screen_all(cal.obs, cal.base, st.model, st.coords, st.n_modes, cands, st)
    return [_screen_solved(cal, c) if c.term is None else f for c, f in zip(cands, first)]


#: On a space frame's sparse path, the first-order screen's shortlist looked at along the
#: candidates' grids (`look_at_clipped`): this many times the number fitted.
LOOK_SHORTLIST = 3


def look_at_clipped(cal: Calibration, cands: list[Candidate], screened: list[tuple[float, float]],
                    n_fit: int | None) -> list[tuple[float, float]]:
    """`screened` with each candidate of the first-order shortlist (the `LOOK_SHORTLIST` x
    `n_fit` largest drops) whose linear step stops at its upper bound judged, as on the dense
    path, by the larger promise of that step and of a look at a few sizes along its grid
    (`fit.look_along`). Space frames on the sparse path only (the dense path looks at every
    candidate already; a planar screen is left as it is).

    A step clipped at the bound is where the linearisation is least to be trusted: the
    residuals' slope asks for more than the candidate can give, and the promise at the bound is
    an extrapolation. A space weak zone's term is its chord to a = 0.99 (local.py), and a deep
    zone near a column's foot turns a higher mode's shape far from linearly: a corner column's
    zone about ry (10 % of its bending stiffness over 0.2-0.3 of it, frame3d, measured
    rotations) screened 15th at chi^2 650 while its fit reached 422, below every candidate
    fitted (the best of those 523), and `femu diagnose` named a joint of the next column."""
    st = cal.setting
    if (n_fit is None or st.model.layout.planar or not cands
            or solver_path(len(st.local.dofmap.free)) == "dense"):
        return screened
    out = list(screened)
    for i in sorted(range(len(cands)), key=lambda i: -screened[i][0])[:LOOK_SHORTLIST * n_fit]:
        c = cands[i]
        if c.term is not None and screened[i][1] >= c.upper:
            out[i] = max(screened[i], look_along(cal.obs, c, cal.base), key=lambda x: x[0])
    return out


def _screen_solved(cal: Calibration, cand: Candidate) -> tuple[float, float]:
    """The larger promise of the first-order step (`fit.screen`) and of a look at a few sizes
    along the candidate's grid (`fit.look_along`)."""
    return promise(cal.obs, cand, cal.base)


# == 3. select ==================================================================================
@dataclass(frozen=True, eq=False)
class Selected:
    """The test's outcome: the best fitted candidate's index, the dispersion, the record's
    selection, and one scored row per candidate (index -> row, in screening order)."""

    best: int
    dispersion: float
    selection: Selection
    rows: dict[int, CandidateFit]


def select(cal: Calibration, found: Screening, alpha: float) -> Selected:
    """The likelihood-ratio test of the best candidate against the calibrated model."""
    n_params_best = 2
    base, fitted, n = cal.base, found.fitted, len(found.candidates)
    best_i = min(fitted, key=lambda i: fitted[i].chi2)
    best = fitted[best_i]
    dispersion = max(1.0, best.chi2 / cal.obs.dof(n_params_best))  # the verdict's dof
    lr = max(base.chi2 - best.chi2, 0.0) / dispersion
    p_single = 0.5 * chi2_dist.sf(lr, 1) if lr > 0 else 1.0
    p_adj = min(1.0, p_single * n)
    # the chi^2 drop the best candidate must exceed to be significant (the test, inverted)
    threshold = dispersion * chi2_dist.isf(min(1.0, 2.0 * alpha / n), 1)
    selection = Selection(METHOD, alpha, n, threshold, len(fitted), lr, p_single, p_adj, dispersion,
                          AMBIGUITY_CHI2, cal.obs.freq_noise, cal.obs.shape_noise)
    rows = {}
    for i in found.order:
        c = found.candidates[i]
        row = CandidateFit(c.label, c.kind, c.location, found.screened[i][0], i in fitted)
        if i in fitted:
            f = fitted[i]
            row = CandidateFit(c.label, c.kind, c.location, found.screened[i][0], True, f.chi2,
                               base.chi2 - f.chi2, (f.chi2 - best.chi2) / dispersion, c.estimate(f.a, f.s), f.s)
        rows[i] = row
    return Selected(best_i, dispersion, selection, rows)


# == 4. extend ==================================================================================
def extend(cal: Calibration, found: Screening, sel: Selected) -> tuple[Cause, tuple[CandidateFit, ...], FrameModel]:
    """The cause (or the candidates it cannot tell apart), the alternatives, and the calibrated
    model extended by the best candidate."""
    fitted, cands, best = found.fitted, found.candidates, found.fitted[sel.best]
    tied = sorted((i for i in fitted if (fitted[i].chi2 - best.chi2) / sel.dispersion < AMBIGUITY_CHI2),
                  key=lambda i: fitted[i].chi2)
    c_best = cands[sel.best]
    # candidates that differ only in how a loss is spread along one element are one answer
    answers = {(cands[i].kind, str(cands[i].location)) for i in tied}
    identifiable = len(answers) == 1
    p_adj = sel.selection.p_adjusted
    if identifiable:
        cause = Cause(c_best.kind, c_best.location, c_best.estimate(best.a, best.s), True, p_adj, c_best.label)
    else:
        one_kind = len({cands[i].kind for i in tied}) == 1
        one_place = len({str(cands[i].location) for i in tied}) == 1
        cause = Cause(c_best.kind if one_kind else "undetermined", c_best.location if one_place else None, {},
                      False, p_adj, None, tuple(cands[i].label for i in tied),
                      f"{len(answers)} candidates explain the data equally well (chi^2 within "
                      f"{AMBIGUITY_CHI2:.1f} of the best): the data cannot tell them apart")
    alternatives = tuple(sel.rows[i] for i in sorted(fitted, key=lambda i: fitted[i].chi2)
                         if (cands[i].kind, cands[i].location) != (c_best.kind, c_best.location))
    model = cal.setting.model
    extended = scale_stiffness(c_best.extend(best.a), best.s).replace(
        name=f"{model.name}+{c_best.label}", description=f"{model.name} extended by diagnosis: {c_best.label} "
        f"({_describe(c_best.estimate(best.a, best.s))}), stiffness scaled by {best.s:.5f}", source="<diagnosis>")
    return cause, alternatives, extended


def _describe(estimate: dict) -> str:
    return ", ".join(f"{k} {v:.4g}" for k, v in estimate.items() if isinstance(v, (int, float)))


# == 5. gain ====================================================================================
def gain(cal: Calibration, cand: Candidate | None) -> Gain:
    """Refit without the highest quarter of the paired modes and predict them, before (the
    calibrated model) and after (the model extended by `cand`, if any)."""
    used = cal.used
    n_hold = max(1, int(round(len(used) / 4)))
    if len(used) - n_hold < 2:
        return Gain(note="too few modes to hold any out")
    fit_modes, hold = used[:-n_hold], used[-n_hold:]
    noise = {"freq_noise": cal.obs.freq_noise, "shape_noise": cal.obs.shape_noise}
    obs_fit = Observations.of(cal.data, modes=fit_modes, **noise)
    obs_hold = Observations.of(cal.data, modes=hold, **noise)
    s = profiled(obs_fit, cal.hz0, cal.sh0).s
    before = correlate(cal.hz0 * np.sqrt(s), cal.sh0, obs_hold)
    modes = (tuple(int(i) + 1 for i in hold), tuple(int(i) + 1 for i in fit_modes))
    if cand is None:
        return Gain(*modes, before)
    f = fit(obs_fit, cand)
    hz, sh = cand.forward(np.array([f.a]))
    after = correlate(hz[0] * np.sqrt(f.s), sh[0], obs_hold)
    return Gain(*modes, before, after, cand.estimate(f.a, f.s), prediction_interval_hz=_predicted(
        obs_fit, obs_hold, cand, f, after.model_hz))


def _predicted(obs_fit: Observations, obs_hold: Observations, cand: Candidate, f: Fit, at_best) -> tuple:
    """The held-out frequencies (Hz) predicted at both ends of the effect's profile interval
    (fitted on the other modes) and at its best: per held-out mode, [lowest, highest]."""
    low, high = profile_interval(obs_fit, cand, f, max(1.0, f.chi2 / obs_fit.dof(2)))
    preds = [np.asarray(at_best, dtype=float)]
    for end in chi2_batch(obs_fit, cand, np.array([v for v in (low, high) if v is not None])):
        hz, sh = cand.forward(np.array([end.a]))
        preds.append(correlate(hz[0] * np.sqrt(end.s), sh[0], obs_hold).model_hz)
    stacked = np.vstack(preds)
    return tuple((float(np.nanmin(c)), float(np.nanmax(c))) for c in stacked.T)
