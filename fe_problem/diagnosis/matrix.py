"""`diagnose_matrix(model, data)`: the diagnosis of a model given as matrices (docs/matrix-model.md).

The same method as a frame's (core.py), on the classes its matrices allow (matrix_kinds.py):

1. Calibrate the global stiffness-to-mass scale (`fit.profiled`), pair the measured modes, run
   the data checks (datachecks.py) and leave a fault out as a frame's diagnosis does.
2. Screen every candidate (each term's loss and gain, a mass and a spring to ground at each
   measured DOF) by one exact step and a look along its grid (`fit.promise`), fit the most
   promising (`core.to_fit`: the `n_fit` best and the two best of every kind) by the grid and
   bounded refinement of `fit.fit`.
3. The likelihood-ratio test of the best against the calibrated model, Bonferroni over the
   candidates, quasi-likelihood dispersion (`core.select`); ties within 2 ln 20 named.
4. The classes scored by their Laplace evidence (evidence.py): no effect, every fitted
   candidate and "every term, sparse" (`every_term_sparse`: which terms changed when several
   did, the ARD localisation and evidence of sparse_class.py over the terms' relative changes).
   The answer is the best class as answer.py chooses it, decisive or not, with the same rules
   (a factor of 10 to the next different answer, enough residual degrees of freedom, no data
   fault).
5. The extended model (a matrix model: the terms' multipliers changed, a new mass or spring
   term, the global scale on every stiffness term), the gain on held-out modes (`core.gain`) and
   the verdict against the noise (verdict.py).

One local cause is named (no further rounds as for frames): changes of several terms at once are
the sparse class's. Every solve goes through one `MatrixSystem` (matrix_setting.py): sparse,
DOFs without mass exact.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..correlation import correlate
from ..matrix_model import MatrixModel
from ..modal_data import DataFileError, ModalData, load_modal_data
from . import answer, dropped, plausibility, sparse_class
from .core import (ALPHA, DEFAULT_FREQ_NOISE, DEFAULT_SHAPE_NOISE, EVIDENCE_METHODS, N_FIT, N_HELD_OUT, _check,
                   _fault_notes, _fault_undecided, _held_out_error, _one_per_answer, _richest_reduced, check_noise,
                   data_checks)
from .steps import AMBIGUITY_CHI2, MIN_MODES, Calibration, Screening, gain, select, to_fit
from .datachecks import FAULTS, left_out, spurious_modes, without
from .evidence import FACTOR_10, ScoredClass, occam_log_factor, ranked, sides_log_prior
from .fit import chi2_batch, fit, profiled, promise
from .kinds import label_log_prior
from .matrix_kinds import matrix_candidates, varied_terms
from .nested import require_dynesty, rescored
from .matrix_setting import MatrixSetting
from .record import Cause, Diagnosis, Found, Noise, Residuals
from .residuals import Observations
from .screening import screen_all
from .verdict import interval_of, profile_interval, verdict

#: The sparse class's kind (its label: every_term_sparse@terms=a+b).
SPARSE_KIND = "every_term_sparse"


def diagnose_matrix(model: MatrixModel, data: ModalData | str, freq_noise: float | None = None,
                    shape_noise: float | None = None, kinds=None, n_fit: int | None = N_FIT, alpha: float = ALPHA,
                    evidence: str = "laplace", keep_faulty: bool = False) -> Diagnosis:
    """Diagnose what the matrix model `model` misses in `data` (see the module docstring; the
    arguments as `core.diagnose`'s; kinds: of matrix_kinds.MATRIX_KINDS; evidence ``nested``: the
    best classes by Laplace scored again by dynesty's nested sampling, nested.py, as a frame's)."""
    if evidence not in EVIDENCE_METHODS:
        raise ValueError(f"evidence must be one of {', '.join(EVIDENCE_METHODS)}, got {evidence!r}")
    if evidence == "nested":
        require_dynesty()  # before the work: a missing dependency fails at once
    with dropped.recording() as failed:
        diag = _diagnose(model, data, freq_noise, shape_noise, kinds, n_fit, alpha, keep_faulty, evidence)
    if not failed:
        return diag
    notes = tuple(f"{label} dropped: {why}; left out of the fits, the test and the evidence" for label, why in failed.items())
    return dataclasses.replace(diag, warnings=diag.warnings + notes,
                               dropped=tuple({"label": k, "reason": v} for k, v in failed.items()))


def calibrate_matrix(model: MatrixModel, data: ModalData, freq_noise: float, shape_noise: float) -> Calibration:
    """The calibrated model (global scale profiled) of a matrix model, as `core.calibrate` gives a
    frame's: measured modes that pair with no model mode are shown, never fitted."""
    st = MatrixSetting.of(model, data.dofs, data.n_modes + 6)
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


#: The first-order screen's shortlist looked at by exact solves (`fit.promise`): this many times
#: the number fitted (`steps.LOOK_SHORTLIST`, the frames' rule for a first-order screen).
LOOK_SHORTLIST = 3


def screen_and_fit_matrix(cal: Calibration, kinds, n_fit: int | None) -> Screening:
    """Every candidate screened to first order from one set of modes and its term (screening.py:
    d lambda = phi^T (dK - lambda dM) phi, the shapes' change through one bordered adjoint
    factorisation per paired mode, on the model's own sparse matrices, DOFs without mass
    included), the `LOOK_SHORTLIST` x `n_fit` most promising (every one where there are fewer,
    or with n_fit None) judged besides by an exact step and a look along their grid
    (`fit.promise`: the larger of the two kept); the most promising fitted (`steps.to_fit`)."""
    st = cal.setting
    cands = matrix_candidates(st, kinds)
    first = dropped.guarded("the first-order screen", lambda: screen_all(
        cal.obs, cal.base, st.model, st.coords, st.n_modes, cands, st.screen_setting), None)
    if first is None:  # its factorisation failed: every candidate by exact steps
        first = [(float("nan"), float("nan"))] * len(cands)
    exact = [i for i, f in enumerate(first) if not np.all(np.isfinite(f))]  # no term (a large one), or failed
    ranked_first = sorted((i for i in range(len(cands)) if i not in set(exact)), key=lambda i: -first[i][0])
    shortlist = ranked_first if n_fit is None else ranked_first[:LOOK_SHORTLIST * n_fit]
    screened = [(0.0, 0.0) if i in set(exact) else first[i] for i in range(len(cands))]
    for i in shortlist:
        screened[i] = max(first[i], promise(cal.obs, cands[i], cal.base), key=lambda x: x[0])
    for i in exact:
        screened[i] = promise(cal.obs, cands[i], cal.base)
    screened = [(0.0, 0.0) if dropped.is_dropped(c.label) else x for c, x in zip(cands, screened)]
    order, chosen = to_fit(cands, screened, n_fit)
    fitted = {i: fit(cal.obs, cands[i], screened[i][1]) for i in order
              if i in chosen and not dropped.is_dropped(cands[i].label)}
    fitted = {i: f for i, f in fitted.items() if not dropped.is_dropped(cands[i].label)}
    order = [i for i in order if i in fitted] + [i for i in order if i not in fitted]
    return Screening(cands, screened, order, fitted)


# == "every term", sparse ========================================================================
class AllTerms:
    """Every varied term's relative change theta (multiplier initial (1 + theta)) as the parameters
    of sparse_class's localisation (the interface of `sparse_class._AllMembers`: names, ids,
    modes, residuals, jacobian)."""

    def __init__(self, st: MatrixSetting):
        self.st = st
        terms = varied_terms(st.model)
        self.names = [t.name for t in terms]
        self.ids = list(self.names)
        self.cols = np.array([st.columns[t.name] for t in terms], dtype=int)
        self.initial = np.array([t.initial for t in terms])
        self.weights = None

    def modes(self, theta: np.ndarray):
        """Frequencies (b, k) and shapes at the measured DOFs for theta (b, n)."""
        theta = np.atleast_2d(theta)
        x = np.repeat(self.st.x0[None, :], len(theta), axis=0)
        x[:, self.cols] = self.initial[None, :] * (1.0 + theta)
        return self.st.solve(x)

    def residuals(self, obs: Observations, theta: np.ndarray, pairing=None) -> list:
        hz, sh = self.modes(theta)
        return [profiled(obs, hz[i], sh[i], pairing) for i in range(hz.shape[0])]

    def jacobian(self, obs: Observations, theta: np.ndarray, cols: np.ndarray, pairing) -> tuple:
        batch = np.repeat(theta[None, :], len(cols) + 1, axis=0)
        batch[1 + np.arange(len(cols)), cols] += sparse_class.STEP
        fits = self.residuals(obs, batch, pairing)
        r0 = fits[0].residuals
        return r0, np.column_stack([(f.residuals - r0) / sparse_class.STEP for f in fits[1:]])


def sparse_label(sf) -> str:
    return f"{SPARSE_KIND}@terms={'+'.join(str(t) for t in sf.members)}"


def sparse_estimate(sf) -> dict:
    return {"terms": list(sf.members), "ratio": [float(1 + t) for t in sf.theta],
            "ratio_std": [float(x) for x in sf.theta_std], "global_scale": sf.s}


def fit_sparse_terms(cal: Calibration):
    """(the sparse class's fit, its parameters) or (None, None): fewer than two varied terms, or ARD
    keeps none."""
    am = AllTerms(cal.setting)
    if len(am.names) < 2:
        return None, am
    sf = dropped.guarded("every term (sparse)", lambda: sparse_class.fit_sparse(
        cal.setting, cal.obs, cal.base.pairing, am=am), None)
    return sf, am


# == the steps ===================================================================================
def _diagnose(model, data, freq_noise, shape_noise, kinds, n_fit, alpha, keep_faulty, evidence="laplace") -> Diagnosis:
    data = load_modal_data(data)
    _check(model, data)
    noise = Noise(DEFAULT_FREQ_NOISE if freq_noise is None else check_noise(freq_noise, "freq_noise"),
                  DEFAULT_SHAPE_NOISE if shape_noise is None else check_noise(shape_noise, "shape_noise"),
                  "default" if freq_noise is None and shape_noise is None else "stated",
                  data_deviations=(int(data.has_frequency_std.sum()), int(data.has_shape_std.sum()), data.n_modes))
    cal = calibrate_matrix(model, data, noise.freq_noise, noise.shape_noise)
    checks = data_checks(cal)
    leave = {} if keep_faulty else left_out(checks)
    if leave:
        cleaned = without(data, leave)
        try:
            if len(cleaned.dofs) < 2:
                raise DataFileError("fewer than 2 channels left")
            cal, data = calibrate_matrix(model, cleaned, noise.freq_noise, noise.shape_noise), cleaned
        except DataFileError:
            leave = {}
    faulty = tuple(c for c in checks if c.kind in FAULTS)
    st, obs, base = cal.setting, cal.obs, cal.base
    found = screen_and_fit_matrix(cal, kinds, n_fit)
    if not found.fitted:
        raise DataFileError(f"{data.source}: no candidate of model {model.name!r} could be fitted")
    sel = select(cal, found, alpha)
    significant = sel.selection.p_adjusted < alpha
    sf, am = fit_sparse_terms(cal)
    ev, by_label = _evidence(cal, found, sf, am, evidence)
    v_none = verdict(obs, base, 1, alpha, what="the calibrated model (no candidate significant)")
    sparse_fit = None if sf is None else am.residuals(obs, _theta(am, sf)[None])[0]
    best = ev.best
    # no local candidate significant, the calibrated model misfits and the sparse class fits within
    # the noise with more than ln 10 of evidence over no effect: that class is the answer (core._beyond_the_test)
    beyond = (not significant and not v_none.adequate and best is not None and best.family == "sparse"
              and best.log_evidence >= FACTOR_10 and verdict(obs, sparse_fit, 1 + len(sf.theta), alpha).adequate)
    c_best = found.candidates[sel.best]
    search = ("local", c_best.key.place.label()) if significant else ("none", answer.NONE_LABEL)
    row, runner, decisive = answer.choose(ev, search, significant or beyond, obs)
    warnings = list(cal.warnings)
    causes = ()
    if row.family == "sparse":
        why = ("the answer is the best class by evidence (sparse: " + row.label + ")" if significant else
               f"no local candidate is significant (p {sel.selection.p_adjusted:.3g}), but the calibrated model does "
               f"not fit within the noise and the class {row.label} does, with log evidence {row.log_evidence:.3g} "
               "over no effect: it is the answer")
        cause = Cause(SPARSE_KIND, {"terms": list(sf.members)}, sparse_estimate(sf), True, sel.selection.p_adjusted,
                      row.label, explanation=why)
        cause = plausibility.judged(st.model, cause)
        extended = _named(st, st.with_scale(st.model.with_initials(
            {n: i * (1.0 + t) for n, i, t in zip(am.names, am.initial, _theta(am, sf)) if t != 0.0}), sf.s), [cause])
        gained = gain(cal, None)
        held = sparse_class.held_out(st, cal.data, cal.used, sf, obs.freq_noise, obs.shape_noise, am)
        if held is not None:
            gained = dataclasses.replace(gained, after=held[0], estimate_from_fit_modes=sparse_estimate_dict(held[1]))
        v = verdict(obs, sparse_fit, 1 + len(sf.theta), alpha, what=f"the best class by evidence, {row.label},")
        warnings.append(why)
        n_params = 1 + len(sf.theta)
    elif significant:
        cause, f_best = _cause(cal, found, sel)
        cause = plausibility.judged(st.model, cause)
        cand = c_best
        extended = _named(st, st.with_scale(cand.extend(f_best.a), f_best.s), [cause])
        gained = gain(cal, cand)
        v = verdict(obs, f_best, 2, alpha)
        low, high = profile_interval(obs, cand, f_best, sel.dispersion)
        causes = (Found(cause.kind, cause.location, cand.estimate(f_best.a, f_best.s),
                        interval_of(cand, low, high, f_best.s), cand.label, sel.selection.p_adjusted,
                        cause.identifiable, cause.indistinguishable, cause.plausible, cause.implausible_because),)
        if cause.explanation:
            warnings.append(cause.explanation)
        n_params = 2
    else:
        cause = Cause("none", None, {}, True, sel.selection.p_adjusted, explanation="no candidate explains the "
                      "residuals significantly better than the calibrated model")
        extended, gained, v, n_params = None, gain(cal, None), v_none, 1
    if not v.adequate:
        warnings.append(v.explanation)
    if not cause.plausible:
        warnings.append(f"implausible estimate: {cause.label}: {cause.implausible_because}")
    few = plausibility.few_dof_note(v.dof, n_params)
    if few:
        warnings.append(few)
    answered = answer.record(row, runner, decisive, cause)
    thin = _fault_undecided(faulty) or answer.dof_note(row, obs) or _misfit_note(row, v)
    answered = dataclasses.replace(answered, decisive=False, not_decisive_because=thin) if thin else answered
    undecided = thin or answer.undecided_note(answered)
    if undecided:
        warnings.append(f"answer not decisive: {undecided}")
    if ev.note and answered.label != ev.classes[0].label:
        warnings.append("evidence: " + ev.note)
    if len(cal.unpaired):
        checks = checks + spurious_modes(cal.unpaired, cal.unpaired, cal.obs_all.frequencies_hz, ())
    if cause.is_none:
        alternatives = tuple(sel.rows[i] for i in found.order[:3] if i in found.fitted)
    else:
        alternatives = tuple(sel.rows[i] for i in sorted(found.fitted, key=lambda i: found.fitted[i].chi2)
                             if found.candidates[i].label != c_best.label)
    return Diagnosis(cause, alternatives, _residuals(cal), gained, tuple(sel.rows.values()), sel.selection, extended,
                     tuple(warnings + _fault_notes(checks, leave, keep_faulty)), causes, v, noise, checks, ev,
                     answered, left_out=leave)


def _misfit_note(row: ScoredClass, v) -> str | None:
    """Why an answer that does not fit within the noise is not decisive (None: it fits, or it is no
    effect): a change the matrix classes cannot express (a part of a term: one column of a storey
    given as one matrix) leaves a misfit that the classes share out by chance (a one-bay frame's
    column at 0.6 of its bending stiffness was named a mass at a floor, decisively, chi^2 287)."""
    if row is None or row.family == "none" or v.adequate:
        return None
    return (f"the answer does not fit within the noise (reduced chi^2 {v.reduced_chi2:.3g}): the change may lie "
            "inside a term (a part of a substructure's matrix), which no class of a matrix model can express")


def sparse_estimate_dict(estimate: dict) -> dict:
    """sparse_class's estimate of a refit (members, modulus ratios) in the terms' words."""
    return {"terms": list(estimate["members"]), "ratio": estimate["modulus_ratio"],
            "ratio_std": estimate["modulus_ratio_std"], "global_scale": estimate["global_scale"]}


def _theta(am: AllTerms, sf) -> np.ndarray:
    theta = np.zeros(len(am.names))
    theta[[am.names.index(x) for x in sf.members]] = sf.theta
    return theta


def _evidence(cal: Calibration, found: Screening, sf, am, evidence: str = "laplace"):
    """The evidence table (core.score_classes' rules on the matrix classes) and label -> candidate;
    evidence ``nested``: its best classes scored again by nested sampling (`nested.rescored`)."""
    obs, base = cal.obs, cal.base
    fits = [(found.candidates[i], f) for i, f in found.fitted.items() if not dropped.is_dropped(found.candidates[i].label)]
    reduced = [base.chi2 / obs.dof(1)] + [f.chi2 / obs.dof(2) for _, f in fits] + _richest_reduced(obs, sf)
    d = max(1.0, min(reduced))
    classes = [ScoredClass(answer.NONE_LABEL, "none", 0, base.chi2, 0.0)]
    for cand, f in fits:
        occam = occam_log_factor(lambda a, c=cand: [x.chi2 for x in chi2_batch(obs, c, np.asarray(a))], f.a,
                                 cand.upper, d) + label_log_prior(cal.setting, cand)
        classes.append(ScoredClass(cand.label, "local", 1, f.chi2, -(f.chi2 - base.chi2) / (2 * d) + occam,
                                   cand.estimate(f.a, f.s), keys=(cand.key,)))
    if sf is not None and len(sf.members) > 1:  # one term changed: that term's local class itself
        held = dropped.guarded("every term (sparse)", lambda: sparse_class.held_out_error(
            cal.setting, cal.data, cal.used, sf, obs.freq_noise, obs.shape_noise, am), None)
        classes.append(ScoredClass(sparse_label(sf), "sparse", len(sf.members), sf.chi2,
                                   -(sf.chi2 - base.chi2) / (2 * d) + sf.log_occam(d),
                                   sparse_estimate(sparse_class.with_dispersion(sf, d)), held))
    ev = ranked(_one_per_answer(classes), "laplace", d)
    by_label = {c.label: c for c, _ in fits}
    out = []
    for k, c in enumerate(ev.classes):
        if k < N_HELD_OUT and (c.label in by_label or c.family == "none"):
            c = dataclasses.replace(c, held_out_error_pct=_held_out_error(cal, by_label.get(c.label)))
        out.append(c)
    ev = dataclasses.replace(ev, classes=tuple(out))
    if evidence == "nested":
        integrands = {c.label: (lambda a, c=c: chi2_batch(obs, c, np.asarray(a[:1]))[0].chi2, 0.0, c.upper,
                                label_log_prior(cal.setting, c)) for c, _ in fits}
        if sf is not None and len(sf.members) > 1:
            integrands[sparse_label(sf)] = (sparse_class.chi2_function(cal.setting, obs, sf, am),
                                            *sparse_class.sided(sf.theta),
                                            -sf.support_log_penalty + sides_log_prior(len(sf.theta)))
        ev = rescored(ev, integrands, base.chi2, d)
    return ev, by_label


def _cause(cal: Calibration, found: Screening, sel):
    """The cause (or the candidates it cannot tell apart, as `core.extend` names them) and the best fit."""
    fitted, cands, best = found.fitted, found.candidates, found.fitted[sel.best]
    tied = sorted((i for i in fitted if (fitted[i].chi2 - best.chi2) / sel.dispersion < AMBIGUITY_CHI2),
                  key=lambda i: fitted[i].chi2)
    c_best = cands[sel.best]
    answers = {(cands[i].kind, str(cands[i].location)) for i in tied}
    p_adj = sel.selection.p_adjusted
    if len(answers) == 1:
        return Cause(c_best.kind, c_best.location, c_best.estimate(best.a, best.s), True, p_adj, c_best.label), best
    one_kind = len({cands[i].kind for i in tied}) == 1
    one_place = len({str(cands[i].location) for i in tied}) == 1
    return Cause(c_best.kind if one_kind else "undetermined", c_best.location if one_place else None, {}, False, p_adj,
                 None, tuple(cands[i].label for i in tied),
                 f"{len(answers)} candidates explain the data equally well (chi^2 within {AMBIGUITY_CHI2:.1f} of the "
                 "best): the data cannot tell them apart"), best


def _named(st: MatrixSetting, extended: MatrixModel, causes) -> MatrixModel:
    what = "; ".join(f"{c.label}" for c in causes if c.label)
    return dataclasses.replace(extended, name=f"{st.model.name}+{'+'.join(c.label or c.kind for c in causes)}",
                               source="<diagnosis>", description=f"{st.model.name} extended by diagnosis: {what}")


def _residuals(cal: Calibration) -> Residuals:
    """`core.residuals_of` for a matrix model: no element moduli to pin."""
    base = cal.base
    dofs = tuple((int(d[0]), str(d[1])) if isinstance(d, tuple) else (int(d), "") for d in cal.data.dofs)
    return Residuals(correlate(cal.hz0 * np.sqrt(base.s), cal.sh0, cal.obs_all, cal.base_all.pairing),
                     base.s, base.chi2, cal.obs.n_residuals, base.chi2 / cal.obs.dof(1),
                     tuple(int(i) + 1 for i in cal.unpaired), (), dofs)


__all__ = ["AllTerms", "SPARSE_KIND", "calibrate_matrix", "diagnose_matrix", "screen_and_fit_matrix"]
