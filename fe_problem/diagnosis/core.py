"""`diagnose(model, data)`: show what the model gets wrong, name the cause, extend the model,
measure the gain on held-out modes.

Steps
1. Calibrate the global stiffness-to-mass scale (what every model is allowed) and show the
   residuals: frequency errors, MAC matrix, COMAC, pairing, and the element moduli that a
   bounded update (+-1/7 around the calibrated value, the paper's 6-8e10 Pa range) pins to
   a bound.
2. Screen every candidate by its first-order chi^2 drop (and, where a solve is cheap, its
   drop at a few sizes of its grid), fit the promising ones (a batched grid over the effect
   size, then a bounded scalar refinement), and select.
3. Selection: a likelihood-ratio test of the best candidate against the calibrated model.
   Each candidate adds one parameter, bounded at zero, so under "no effect" the statistic is
   a 50:50 mixture of chi^2_0 and chi^2_1; the p-value is multiplied by the number of
   candidates tried (Bonferroni), since the best of many is being tested. The statistic is
   divided by the best model's reduced chi^2 when that exceeds 1 (quasi-likelihood), so a
   remaining misfit makes the test more cautious, never less. Significant at alpha = 0.01,
   otherwise the cause is ``none``. Candidates whose chi^2 lies within 2 ln 20 = 6 of the
   best (likelihood ratio < 20, "strong evidence" on the Kass-Raftery scale) cannot be told
   apart from it: then the cause says so (``identifiable: false``) and lists them, with the
   kind (and place) given only where all of them agree.
4. The extended model (calibrated, with the effect) as a model file.
5. Gain: the highest quarter of the modes (at least one) is held out; the calibrated model
   and the extended model are refitted without them and both predict them, the extended
   model's prediction with the range its effect's profile-likelihood interval gives. (The
   choice of candidate saw every mode; the parameters that make the prediction did not; with
   several causes the last is refitted, the others kept at their sizes.)
6. Further causes (rounds.py), then the final model's goodness of fit against the stated
   noise and each estimate's interval (verdict.py).

Noise convention: `shape_noise` is the std of a shape entry as a fraction of the largest
|entry| of its mode; the defaults are 0.2 % and 2 %. The record states what was used (`noise`)
and what the final model's misfit implies (`goodness_of_fit`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..correlation import correlate
from ..modal_data import DataFileError, ModalData, load_modal_data
from ..matrix_model import MatrixModel
from ..model import FrameModel, load_model
from .candidates import Candidate
from . import plausibility
from .datachecks import FAULTS, DataCheck, check_data, left_out, spurious_modes, without
from .evidence import FACTOR_10, Evidence, ScoredClass, occam_log_factor, ranked, sides_log_prior
from .modelform import model_form_candidates, screen_forms
from .plausibility import few_dof_note
from .fit import Fit, chi2_batch, class_promises, fit, profiled
from . import answer, dropped, group_free, predictive, sparse_class
from .kinds import class_candidates, class_fits, label_log_prior
from .nested import require_dynesty, rescored
from .record import Cause, Diagnosis, Noise
from .verdict import verdict
from .residuals import Observations
from .rounds import STIFFNESS_KINDS, further_causes
from .steps import (AMBIGUITY_CHI2, MIN_MODES, METHOD, Calibration, calibrate, residuals_of, _pinned_moduli,  # noqa: F401
                    Screening, screen_and_fit, to_fit, screen_candidates, LOOK_SHORTLIST, look_at_clipped,
                    _screen_solved, Selected, select, extend, _describe, gain, _predicted)

ALPHA = 0.01
DEFAULT_FREQ_NOISE = 0.002
DEFAULT_SHAPE_NOISE = 0.02


def check_noise(value, name: str) -> float:
    """A stated noise (`name`: freq_noise or shape_noise, or the CLI's option) as a float: a
    relative standard deviation, a fraction in (0, 1). ValueError otherwise: a value of 1 or more
    is a percentage written as a number (2 meant as 2 % would be 200 %), not silently used."""
    v = float(value)
    if not (np.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a number > 0 (a relative standard deviation, e.g. 0.002), got {value}")
    if v >= 1:
        raise ValueError(f"{name} is a fraction, not a percentage: {v:g} would be {100 * v:g} %; "
                         f"for {v:g} % give {v / 100:g}")
    return v
#: Screened candidates fitted besides those always fitted (see `screen_and_fit`).
N_FIT = 12
MAX_CAUSES = 4


def diagnose(model: FrameModel | str | None, data: ModalData | str, freq_noise: float | None = None,
             shape_noise: float | None = None, kinds=None, n_fit: int | None = N_FIT, alpha: float = ALPHA,
             max_causes: int = MAX_CAUSES, evidence: str = "laplace", keep_faulty: bool = False) -> Diagnosis:
    """Diagnose what `model` misses in `data` (see the module docstring for the method).

    freq_noise: std of a measured frequency, relative (default 0.002 = 0.2 %); shape_noise: std
    of a measured shape entry as a fraction of the largest |entry| of its mode (default 0.02 =
    2 %). kinds: candidate kinds to try (default all); n_fit: how many screened candidates are
    fitted properly besides the ones always fitted (None: all); max_causes: at most this many
    causes are added one after another; evidence: how the model classes are scored, ``laplace``
    (at the fitted optimum) or ``nested`` (the best by Laplace sampled with dynesty, seeded:
    nested.py; the optional dependency ``.[nested]``); keep_faulty: fit the channels and modes
    the data checks find faulty too (default: left out, `datachecks.left_out`; either way an
    answer on data with a fault is not decisive).
    """
    if evidence not in EVIDENCE_METHODS:
        raise ValueError(f"evidence must be one of {', '.join(EVIDENCE_METHODS)}, got {evidence!r}")
    if evidence == "nested":
        require_dynesty()  # before the work: a missing dependency fails at once
    with dropped.recording() as failed:
        diag = _diagnose(model, data, freq_noise, shape_noise, kinds, n_fit, alpha, max_causes, evidence, keep_faulty)
    if not failed:
        return diag
    notes = tuple(f"{label} dropped: {why}; left out of the fits, the test and the evidence" for label, why in failed.items())
    return dataclasses.replace(diag, warnings=diag.warnings + notes,
                               dropped=tuple({"label": k, "reason": v} for k, v in failed.items()))


def _diagnose(model, data, freq_noise, shape_noise, kinds, n_fit, alpha, max_causes, evidence,
              keep_faulty=False) -> Diagnosis:
    """`diagnose`'s steps, inside the record of dropped candidates (dropped.py)."""
    data = load_modal_data(data)
    model = data.load_model() if model is None else model
    if isinstance(model, MatrixModel):  # a data file may name a matrix manifest (docs/matrix-model.md)
        raise ValueError(f"{model.source or model.name}: core.diagnose is a frame model's (its candidates are members, "
                         "joints and supports); a model given as matrices is diagnosed by fe_problem.diagnose "
                         "(diagnosis/dispatch.py -> matrix.py)")
    model = load_model(model)
    _check(model, data)
    noise = Noise(DEFAULT_FREQ_NOISE if freq_noise is None else check_noise(freq_noise, "freq_noise"),
                  DEFAULT_SHAPE_NOISE if shape_noise is None else check_noise(shape_noise, "shape_noise"),
                  "default" if freq_noise is None and shape_noise is None else "stated",
                  data_deviations=(int(data.has_frequency_std.sum()), int(data.has_shape_std.sum()), data.n_modes))
    cal = calibrate(model, data, noise.freq_noise, noise.shape_noise)
    checks = data_checks(cal)
    leave = {} if keep_faulty else left_out(checks)
    if leave:  # the faults found are left out of the fit: the search runs on what the data can still say
        cleaned = without(data, leave)
        try:
            if len(cleaned.dofs) < 2:
                raise DataFileError("fewer than 2 channels left")
            cal, data = calibrate(model, cleaned, noise.freq_noise, noise.shape_noise), cleaned
        except DataFileError:  # too little left to diagnose: kept, as with keep_faulty
            leave = {}
    faulty = tuple(c for c in checks if c.kind in FAULTS)
    found = screen_and_fit(cal, kinds, n_fit)
    sel = select(cal, found, alpha)
    warnings = list(cal.warnings)
    if sel.selection.p_adjusted >= alpha:
        cause = Cause("none", None, {}, True, sel.selection.p_adjusted, explanation="no candidate explains the "
                      "residuals significantly better than the calibrated model")
        alternatives = tuple(sel.rows[i] for i in found.order[:3] if i in found.fitted)
        v = verdict(cal.obs, cal.base, 1, alpha, what="the calibrated model (no candidate significant)")
        checks = checks + spurious_modes(cal.unpaired, cal.unpaired, cal.obs_all.frequencies_hz, _explained(checks))
        # the calibrated model misfits: the model-form classes are scored too (as when a cause is found)
        forms = None if v.adequate else model_form_fits(cal)
        cal.setting.baselines.clear()  # (`model_form_fits` clears it too): no later screen of this model
        scored = score_classes(cal, found, None, evidence, forms)
        ev = scored.evidence
        other = _beyond_the_test(cal, scored, v, sel, alpha, model)
        row, runner, decisive = answer.choose(ev, answer.search_key(None), other is not None, cal.obs)
        row, runner, decisive, told, ev = _predicted_choice(cal, scored, row, runner, decisive, lambda c: False)
        gained, extended = gain(cal, None), None
        if other is None:
            if not v.adequate:
                warnings.append(v.explanation)
        else:
            cause, gained, v = other.cause, other.gain, other.verdict
            extended = _named(cal.setting.model, other.extended_model, [cause])
            warnings.append(cause.explanation)
            if not cause.plausible:
                warnings.append(f"implausible estimate: {cause.label}: {cause.implausible_because}")
            few = few_dof_note(v.dof, other.n_params)
            if few:
                warnings.append(few)
        answered = answer.record(row, runner, decisive, cause)
        thin = _fault_undecided(faulty) or answer.dof_note(row, cal.obs) or _unless_decisive(told, decisive)
        answered = dataclasses.replace(answered, decisive=False, not_decisive_because=thin) if thin else answered
        undecided = thin or answer.undecided_note(answered)
        warnings += [told] if told else []
        return Diagnosis(cause, alternatives, residuals_of(cal), gained, tuple(sel.rows.values()),
                         sel.selection, extended, tuple(warnings + _fault_notes(checks, leave, keep_faulty) + _evidence_notes(ev, None, row)
                                                        + ([f"answer not decisive: {undecided}"] if undecided else [])),
                         (), v, noise, checks, ev, answered, left_out=leave)
    cause, alternatives, _ = extend(cal, found, sel)

    forms = model_form_fits(cal)
    explained = _form_explains(cal, forms, found.fitted[sel.best], sel.dispersion, alpha)
    if explained is not None and max_causes > 1:
        warnings.append(f"the local search stopped after its first cause: the model-form class {explained} alone "
                        "fits within the stated noise and better than that cause by a likelihood ratio above 10")
    rounds = further_causes(cal, found, sel, cause, kinds, n_fit, alpha, 1 if explained else max_causes)
    causes = tuple(plausibility.judged(model, c) for c in rounds.causes)
    cause = plausibility.judged(model, _first(cause, causes[0]))
    scored = score_classes(cal, found, rounds, evidence, forms)
    ev = scored.evidence
    row, runner, decisive = answer.choose(ev, answer.search_key(rounds), True, cal.obs)
    key = answer.search_key(rounds)
    row, runner, decisive, told, ev = _predicted_choice(
        cal, scored, row, runner, decisive, lambda c: c.family in answer.NON_LOCAL or answer.answer_key(c) == key)
    if told:
        warnings.append(told)
    gained, n_params = rounds.gain, 1 + len(rounds.causes)
    if row.family in answer.NON_LOCAL:  # the best class by evidence is not the local search's
        other = answer.non_local(cal, row, scored.fitted, scored.sparse, sel.selection.p_adjusted, alpha, model,
                                 gain, [c.label or f"{c.kind} ({len(c.indistinguishable)} candidates tie)"
                                        for c in causes], scored.groups)
        cause, gained, v, n_params = other.cause, other.gain, other.verdict, other.n_params
        extended = _named(cal.setting.model, other.extended_model, [cause])
    else:
        v = verdict(rounds.obs, rounds.final, n_params, alpha)
        extended = _named(cal.setting.model, rounds.model, rounds.causes)
    if cause.explanation:
        warnings.append(cause.explanation)
    if not v.adequate:
        warnings.append(v.explanation)
    judged = causes + ((cause,) if row.family in answer.NON_LOCAL else ())
    warnings += [f"implausible estimate: {c.label}: {c.implausible_because}" for c in judged if not c.plausible]
    few = few_dof_note(v.dof, n_params)
    if few:
        warnings.append(few)
    answered = answer.record(row, runner, decisive, cause)
    thin = _fault_undecided(faulty) or answer.dof_note(row, cal.obs) or _unless_decisive(told, decisive)
    answered = dataclasses.replace(answered, decisive=False, not_decisive_because=thin) if thin else answered
    undecided = thin or answer.undecided_note(answered)
    if undecided:
        warnings.append(f"answer not decisive: {undecided}")
    if len(cal.unpaired):
        final_unpaired = calibrate(rounds.model, data, noise.freq_noise, noise.shape_noise, model).unpaired
        checks = checks + spurious_modes(cal.unpaired, final_unpaired, cal.obs_all.frequencies_hz, _explained(checks))
    return Diagnosis(cause, alternatives, residuals_of(cal), gained, tuple(sel.rows.values()), sel.selection,
                     extended, tuple(warnings + _fault_notes(checks, leave, keep_faulty) + _evidence_notes(ev, rounds, row)), causes, v,
                     noise, checks, ev, answered, left_out=leave)


def _predicted_choice(cal: "Calibration", scored: "Scored", row, runner, decisive: bool, may_answer):
    """The answer's row, runner-up and decisiveness after the predictive rule (predictive.py: when no
    class fits within the noise, a class not decisively apart in evidence that predicts the modes left
    out better is the answer, and a different answer that predicts them better makes it not decisive),
    the sentence saying so (None: nothing changed), and the evidence with the classes' predictions."""
    preds = dropped.guarded("the leave-one-mode-out predictions", lambda: predictive.predictions(
        cal, scored, None if row is None else row.label), {})
    ev = scored.evidence
    if not preds:
        return row, runner, decisive, None, ev
    row, runner, decisive, told = predictive.follow(ev, preds, row, runner, decisive, may_answer, answer.same_answer)
    return row, runner, decisive, told, dataclasses.replace(ev, predictive=tuple(p.to_dict() for p in preds.values()))


def _unless_decisive(told: str | None, decisive: bool) -> str | None:
    """The predictive rule's sentence as the reason an answer is not decisive (None when it is)."""
    return None if decisive or not told else told


def _beyond_the_test(cal: "Calibration", scored: "Scored", v, sel: "Selected", alpha: float,
                     model: FrameModel) -> "answer.NonLocal | None":
    """The answer when no local candidate is significant, but the calibrated model does not fit within
    the noise (its verdict `v`) and the best class by evidence is a non-local one (distributed,
    sparse, model-form: none of them is among the test's candidates) that has more than ln 10 of log
    evidence over no effect and fits within the noise itself (its verdict): that class, with its
    extended model, held-out gain and verdict (answer.non_local). Else None (the answer is none).
    The test asks whether any local candidate is there; a member 2 % thinner is none of them."""
    best = scored.evidence.best
    if v.adequate or best is None or best.family not in answer.NON_LOCAL or best.log_evidence < FACTOR_10:
        return None
    p = sel.selection.p_adjusted
    why = (f"no local candidate is significant (p {p:.3g}), but the calibrated model does not fit within the noise "
           f"(reduced chi^2 {v.reduced_chi2:.3g}) and the best class by evidence, {best.label} ({best.family}), "
           f"does, with log evidence {best.log_evidence:.3g} over no effect: it is the answer")
    other = answer.non_local(cal, best, scored.fitted, scored.sparse, p, alpha, model, gain, [], scored.groups, why)
    return other if other.verdict.adequate else None


# == evidence between model classes (evidence.py, groups.py) ====================================
#: Distributed classes fitted (the best screened), and classes whose held-out error is given.
N_DISTRIBUTED_FIT, N_HELD_OUT = 8, 6
#: Model-form classes fitted (the best screened).
N_FORM_FIT = 6
#: How the classes' evidence is found (`diagnose(evidence=...)`, `femu diagnose --evidence`).
EVIDENCE_METHODS = ("laplace", "nested")


@dataclass(frozen=True, eq=False)
class Scored:
    """The evidence table, and what its classes were fitted with: label -> (candidate, Fit) of every
    fitted one-parameter class, the sparse class's fit (None: not scored) and label -> fit of the
    free group classes scored (group_free.GroupFit)."""

    evidence: Evidence
    fitted: dict
    sparse: object = None
    groups: dict = dataclasses.field(default_factory=dict)


def model_form_fits(cal: "Calibration") -> list[tuple[Candidate, Fit]]:
    """The model-form classes (modelform.py: every node, element and support) screened by one step
    (`screen_forms`), the `N_FORM_FIT` most promising fitted (`coarse_fit`)."""
    obs, base = cal.obs, cal.base
    forms = model_form_candidates(cal.setting)
    drops = [d for d, _ in screen_forms(obs, base, cal.setting, forms)]
    cal.setting.baselines.clear()  # the last screen of this model: its adjoint blocks (87 MB at 3,024 DOFs) go
    drops = [0.0 if dropped.is_dropped(c.label) else d for c, d in zip(forms, drops)]  # a failed solve: not fitted
    best = [i for i in sorted(range(len(forms)), key=lambda i: -drops[i])[:N_FORM_FIT]]
    out = [(forms[i], coarse_fit(obs, forms[i])) for i in best if not dropped.is_dropped(forms[i].label)]
    return [(c, f) for c, f in out if not dropped.is_dropped(c.label)]


def _form_explains(cal: "Calibration", forms, first: Fit, dispersion: float, alpha: float) -> str | None:
    """The label of the best model-form class when it alone fits within the noise (the verdict's
    test) and its chi^2 lies below the first cause's by more than 2 ln 10 times the dispersion (a
    likelihood ratio above 10, one parameter each): then further local causes would only mend a
    model-form error (a pinned base drew four causes and minutes), and the rounds stop. Else None."""
    if not forms:
        return None
    cand, f = min(forms, key=lambda x: x[1].chi2)
    if f.chi2 < first.chi2 - 2.0 * FACTOR_10 * dispersion and verdict(cal.obs, f, 2, alpha).adequate:
        return cand.label
    return None


def score_classes(cal: "Calibration", found: "Screening", rounds, evidence: str = "laplace",
                  forms: list | None = None) -> Scored:
    """Every class scored by its Laplace evidence against the calibrated model: no effect, each
    fitted local candidate, the best-screened distributed classes (groups.py), the free group
    classes (group_free.py: every storey, column line or floor free, two adjacent members free),
    "every member" sparse (sparse_class.py), the model-form classes (when a cause was found; `forms`, as
    `model_form_fits` gives them, when already fitted) and the local
    search's result: with several causes the model with all of them, with one its cause when no
    first-round fit is at its place; the best few with their held-out prediction error. evidence
    ``nested``: the best classes by Laplace scored again by nested sampling (nested.py; the
    local search's own row keeps its Laplace value)."""
    obs, base = cal.obs, cal.base
    distributed = class_candidates(cal.setting, "distributed")  # the registry's distributed kinds
    promise = class_promises(obs, distributed, base, N_DISTRIBUTED_FIT)
    top = sorted(range(len(distributed)), key=lambda i: -promise[i][0])[:N_DISTRIBUTED_FIT]
    fits = [(found.candidates[i], f, "local") for i, f in found.fitted.items()]
    fits += [(distributed[i], fit(obs, distributed[i], promise[i][1]), "distributed") for i in top]
    if rounds is not None or forms:  # the model-form alternatives: every node and element screened, the best fitted
        fits += [(c, f, "model_form") for c, f in (model_form_fits(cal) if forms is None else forms)]
    # the local search's result as a class of its own: several causes, or one at a place the first
    # round did not fit better than no effect (a revisit moved it): `_one_per_answer` keeps no row of it
    several = rounds is not None and (len(rounds.sized) > 1 or answer.search_key(rounds)[1] not in {
        c.key.place.label() for c, f, family in fits if family == "local" and f.chi2 < base.chi2 - 1e-9})
    fits = [x for x in fits if not dropped.is_dropped(x[0].label)]  # a failed solve: no class (dropped.py)
    # the classes fitted as a whole, each through the registry (`kinds.class_fits`, `KindSpec.fit`)
    sparse = dropped.guarded("every member (sparse)", lambda: next(iter(class_fits(
        cal.setting, obs, base.pairing, "sparse")), None), None)  # "every member", sparse (None: n/a)
    partitions = dropped.guarded("the free group classes", lambda: class_fits(
        cal.setting, obs, base.pairing, "distributed"), [])  # every storey / line / floor free
    pair = dropped.guarded("two adjacent members free", lambda: next(iter(class_fits(
        cal.setting, obs, base.pairing, "distributed", pair_seeds(fits, sparse, rounds))), None), None)
    # the dispersion: the smallest reduced chi^2 of the classes (at least 1), the richest class's
    # included (quasi-likelihood practice: the scale from the maximal model) when it leaves at least
    # MIN_DOF residual dof, so that its misfit estimates the noise (`_richest_reduced`). Taken from
    # the best one-parameter class alone, the dispersion of a model that does not fit shrank every
    # likelihood difference until the parameters' charges chose (issue 38: a four-storey frame's
    # storey pattern, chi^2 79, lost to a one-member class, chi^2 257, at a dispersion of 17.8).
    reduced = [base.chi2 / obs.dof(1)] + [f.chi2 / obs.dof(2) for _, f, _ in fits] + _richest_reduced(obs, sparse)
    searched = _search_fits(obs, rounds) if several else []
    chi2_s = min(f.chi2 for f in searched) if several else None
    if several:
        reduced.append(chi2_s / obs.dof(1 + len(rounds.sized)))
    reduced += [g.fit.chi2 / obs.dof(1 + len(g.fit.theta)) for g in partitions]  # not the pair's: chosen among pairs
    d = max(1.0, min(reduced))
    classes = [ScoredClass("calibrated model (no effect)", "none", 0, base.chi2, 0.0)]
    for cand, f, family in fits:
        occam = occam_log_factor(lambda a, c=cand: [x.chi2 for x in chi2_batch(obs, c, np.asarray(a))], f.a,
                                 cand.upper, d) + label_log_prior(cal.setting, cand)
        classes.append(ScoredClass(cand.label, family, 1, f.chi2, -(f.chi2 - base.chi2) / (2 * d) + occam,
                                   cand.estimate(f.a, f.s), keys=(cand.key,)))
    search = []
    if several:
        # on the modes every other row is judged on (`searched`), against the calibrated model's chi^2 there
        occam = sum(occam_log_factor(lambda a, c=c: [x.chi2 for x in chi2_batch(obs, c, np.asarray(a))], f.a,
                                     c.upper, d) + label_log_prior(cal.setting, c)
                    for (c, _), f in zip(rounds.sized, searched))
        one = len(rounds.sized) == 1
        search.append(ScoredClass(" + ".join(c.label for c, _ in rounds.sized), "local" if one else "several",
                                  len(rounds.sized), chi2_s, -(chi2_s - base.chi2) / (2 * d) + occam,
                                  rounds.causes[0].estimate if one else None,
                                  keys=tuple(c.key for c, _ in rounds.sized)))
    if sparse is not None:
        classes.append(sparse_class.with_dispersion(sparse, d).scored(base.chi2, d, sparse_class.held_out_error(
            cal.setting, cal.data, cal.used, sparse, obs.freq_noise, obs.shape_noise)))
    groups = {g.label: g for g in partitions + ([pair] if pair is not None else [])}
    for g in groups.values():
        classes.append(g.scored(base.chi2, d, group_free.held_out_error(
            cal.setting, cal.data, cal.used, g, obs.freq_noise, obs.shape_noise)))
    # the search's result is significant by its own tests: never merged away (its key is its own)
    ev = ranked(_one_per_answer(classes) + search, "laplace", d)
    by_label = {c.label: c for c, _, _ in fits}
    out = []
    for k, c in enumerate(ev.classes):
        if k < N_HELD_OUT and (c.label in by_label or c.family == "none"):
            c = dataclasses.replace(c, held_out_error_pct=_held_out_error(cal, by_label.get(c.label)))
        out.append(c)
    ev = dataclasses.replace(ev, classes=tuple(out))
    if evidence == "nested":
        integrands = {c.label: (lambda a, c=c: chi2_batch(obs, c, np.asarray(a[:1]))[0].chi2, 0.0, c.upper,
                                label_log_prior(cal.setting, c)) for c, _, _ in fits}
        if sparse is not None:
            integrands[sparse.label] = (sparse_class.chi2_function(cal.setting, obs, sparse),
                                        *sparse_class.sided(sparse.theta),
                                        -sparse.support_log_penalty + sides_log_prior(len(sparse.theta)))
        integrands.update({label: group_free.integrand(cal.setting, obs, g) for label, g in groups.items()})
        ev = rescored(ev, integrands, base.chi2, d)
    return Scored(ev, answer.fitted_candidates(fits), sparse, groups)


def _richest_reduced(obs: Observations, sparse) -> list[float]:
    """The "every member" sparse class's reduced chi^2 as a candidate for the evidence's dispersion
    (`score_classes`), when it leaves at least `plausibility.MIN_DOF` residual dof; else none
    (with many members and few data its misfit says little about the noise)."""
    if sparse is None:
        return []
    dof = obs.n_residuals - obs.n_shape_modes - 1 - len(sparse.theta)
    return [sparse.chi2 / dof] if dof >= plausibility.MIN_DOF else []


#: Local stiffness classes (the best by chi^2) whose elements seed the two-adjacent-members class.
N_PAIR_SEEDS = 3


def pair_seeds(fits, sparse, rounds) -> set[int]:
    """The elements whose chains the two-adjacent-members class is fitted on (group_free.fit_pair):
    those of the `N_PAIR_SEEDS` best local stiffness classes fitted, of the local search's causes
    and of the sparse class's members."""

    local = sorted((f.chi2, c.location["element"]) for c, f, family in fits
                   if family == "local" and c.kind in STIFFNESS_KINDS and "element" in (c.location or {}))
    out = {e for _, e in local[:N_PAIR_SEEDS]}
    if rounds is not None:
        out |= {c.location["element"] for c, _ in rounds.sized if c.kind in STIFFNESS_KINDS
                and "element" in (c.location or {})}
    return out | (set(sparse.members) if sparse is not None else set())


def _search_fits(obs: Observations, rounds) -> list[Fit]:
    """The local search's model (every cause of `rounds`) judged on `obs`, the modes that pair with
    the calibrated model, on which every other class of the evidence table is judged: each cause's
    size refitted there with the others at theirs (as `rounds._finish` refits them on the modes that
    pair with the final model); the best of these fits is the class's chi^2. (Judged on the modes
    that pair with the final model instead, a mode only that model pairs entered its chi^2 and its
    calibrated reference, not the other rows': a spring to ground and 30 g scored 15,900 in log
    evidence against 311 for the next class.)"""
    return [fit(obs, c, a_j) for c, a_j in rounds.sized]


def coarse_fit(obs: Observations, cand: Candidate) -> Fit:
    """The best of the candidate's grid, refined once at the vertex of the parabola through it and
    its neighbours: a model-form class builds a model per size, so no scalar search."""
    grid = np.asarray(cand.grid, dtype=float)
    fits = chi2_batch(obs, cand, grid)
    k = int(np.argmin([f.chi2 for f in fits]))
    best = fits[k]
    if 0 < k < len(grid) - 1:
        x, y = grid[k - 1:k + 2], np.array([f.chi2 for f in fits[k - 1:k + 2]])
        den = (x[0] - x[1]) * (x[0] - x[2]) * (x[1] - x[2])
        a2 = (x[2] * (y[1] - y[0]) + x[1] * (y[0] - y[2]) + x[0] * (y[2] - y[1])) / den
        a1 = (x[2] ** 2 * (y[0] - y[1]) + x[1] ** 2 * (y[2] - y[0]) + x[0] ** 2 * (y[1] - y[2])) / den
        if a2 > 0:
            vertex = float(np.clip(-a1 / (2 * a2), x[0], x[2]))
            trial = chi2_batch(obs, cand, np.array([vertex]))[0]
            if trial.chi2 < best.chi2:
                best = trial
    return best


def _one_per_answer(classes: list[ScoredClass]) -> list[ScoredClass]:
    """The best class of each answer: the profiles of one element's loss (a weak zone at several
    places along it, or uniform) are one answer; a class fitted at size 0 is the calibrated model."""
    best: dict = {}
    for c in classes:
        if c.family != "none" and c.estimate is not None and c.chi2 >= classes[0].chi2 - 1e-9:
            continue  # no better than no effect: the calibrated model itself
        key = answer.place_label(c)
        if key not in best or c.log_evidence > best[key].log_evidence:
            best[key] = c
    return list(best.values())


def _held_out_error(cal: "Calibration", cand: Candidate | None) -> float | None:
    """Mean |frequency error| (%) on the held-out modes (as `gain` splits them) of the class refitted
    on the other modes; None when too few modes to hold any out."""
    used = cal.used
    n_hold = max(1, int(round(len(used) / 4)))
    if len(used) - n_hold < 2:
        return None
    noise = {"freq_noise": cal.obs.freq_noise, "shape_noise": cal.obs.shape_noise}
    obs_fit = Observations.of(cal.data, modes=used[:-n_hold], **noise)
    obs_hold = Observations.of(cal.data, modes=used[-n_hold:], **noise)
    if cand is None:
        hz, sh, s = cal.hz0, cal.sh0, profiled(obs_fit, cal.hz0, cal.sh0).s
    else:
        f = fit(obs_fit, cand)
        hz, sh = (x[0] for x in cand.forward(np.array([f.a])))
        s = f.s
    return correlate(hz * np.sqrt(s), sh, obs_hold).mean_abs_error_pct


def _evidence_notes(ev: Evidence, rounds, answered: ScoredClass | None = None) -> list[str]:
    """A sentence when a distributed or sparse class has clearly more evidence than the local search's
    result, one when a model-form class is within a factor of 10 of it or above, each saying whether
    that class is the answer (`answered`), and the factor-of-10 note."""
    notes = []
    best = ev.best
    found = "no effect" if rounds is None else ("the causes found" if len(rounds.sized) > 1 else "the cause found")
    key = answer.search_key(rounds)
    chosen = [c for c in ev.classes if answer.answer_key(c) == key]

    def tail(c: ScoredClass, why: str, as_answer: str) -> str:
        if answered is not None and c.label == answered.label:
            return (f": it is the answer ({as_answer}); {found} by the local search "
                    f"{'stay' if found.startswith('the causes') else 'stays'} in the record (`causes`)")
        return f": {why}"

    if best is not None and best.family in ("distributed", "sparse") and chosen and \
            best.log_evidence - chosen[0].log_evidence >= FACTOR_10:
        notes.append(f"evidence: the {best.family} class {best.label} explains the data better than {found} (log "
                     f"evidence {best.log_evidence:.3g} against {chosen[0].log_evidence:.3g})"
                     + tail(best, "the change may be spread over several members",
                            "the change is spread over several members"))
    form = [c for c in ev.classes if c.family == "model_form"]
    if rounds is not None and form and chosen and form[0].log_evidence > chosen[0].log_evidence - FACTOR_10:
        notes.append(f"model form: {form[0].label} ({', '.join(f'{k} {v:.4g}' if isinstance(v, float) else f'{k} {v}' for k, v in (form[0].estimate or {}).items())}) "
                     f"explains the data {'better than' if form[0].log_evidence > chosen[0].log_evidence else 'about as well as'} "
                     f"{found} (log evidence {form[0].log_evidence:.3g} against {chosen[0].log_evidence:.3g})"
                     + tail(form[0], "the named cause may be an error of the model's geometry, section or supports, "
                                     "not that physics", "an error of the model's geometry, section or supports"))
    if ev.note and (answered is None or answered.label != ev.classes[0].label):
        notes.append("evidence: " + ev.note)  # else the answer's own note says it (answer.undecided_note)
    return notes


def data_checks(cal: "Calibration") -> tuple[DataCheck, ...]:
    """The checks of the data against the calibrated nominal model (datachecks.py)."""
    obs = cal.obs_all
    return check_data(obs.frequencies_hz, obs.shapes, obs.has_shape, cal.hz0, cal.sh0, cal.base_all.s,
                      cal.setting.coords, obs.shape_noise)


def _explained(checks) -> set:
    """1-based modes another check already accounts for: those of a duplicate or exchanged pair,
    and every mode when a channel is faulty (a reversed or swapped channel can drop a mode's MAC
    with every model mode below pairing)."""
    if any(c.kind in ("channel_polarity", "channel_swap") for c in checks):
        return set(range(1, 10**6))
    return {m for c in checks if c.kind in ("duplicate_mode", "mode_order") for m in c.where.get("modes", [])}


def _fault_notes(checks, leave: dict, kept: bool) -> list[str]:
    """One sentence per fault of the data, saying whether the diagnosis left it out (`leave`:
    `datachecks.left_out`) or ran on the data as given (`kept`: keep_faulty, or too little left)."""
    if leave:
        what = "; ".join(f"{k} {', '.join(''.join(map(str, v)) if isinstance(v, list) else str(v) for v in vals)}"
                         for k, vals in leave.items())
        after = (f"The diagnosis left out of its fit {what} (mode numbers in the rest of the record count the modes "
                 "left in)" if "modes" in leave else f"The diagnosis left out of its fit {what}")
    else:
        after = ("The diagnosis ran on the data as given" + (" (keep_faulty)" if kept else "")
                 + "; this fault of the data may explain the misfit and the causes named")
    given = ("The diagnosis ran on the data as given; this fault of the data may explain the misfit and the causes "
             "named")
    return [f"data check: {c.text}. {after if c.kind in FAULTS else given}" for c in checks]


def _fault_undecided(faulty) -> str | None:
    """Why an answer on data with a fault is not decisive (None: no fault): what the fault hid
    or changed, left out or not, may be where the structure differs from its model."""
    if not faulty:
        return None
    return (f"the data have a fault ({', '.join(dict.fromkeys(c.kind for c in faulty))}): an answer on faulty data "
            "is never decisive (datachecks.FAULTS)")


def _first(cause: Cause, first) -> Cause:
    """The cause as the rounds leave it: chosen again with the other causes in the model (it may
    be a neighbour of the first round's best, or tie no more), its size refitted jointly."""
    if first.identifiable:
        return Cause(first.kind, first.location, first.estimate, True, first.p_adjusted, first.label)
    if first.indistinguishable == cause.indistinguishable:
        return cause
    return Cause(first.kind, first.location, {}, False, first.p_adjusted, None, first.indistinguishable,
                 f"{len(first.indistinguishable)} candidates explain the data equally well with the other causes "
                 f"in the model (chi^2 within {AMBIGUITY_CHI2:.1f} of the best): the data cannot tell them apart")


def _named(model: FrameModel, extended: FrameModel, causes) -> FrameModel:
    """The extended model with a name and description that say what was added."""
    labels = [c.label or c.kind for c in causes]
    what = "; ".join(f"{c.label} ({_describe(c.estimate)})" for c in causes if c.label)
    return extended.replace(name=f"{model.name}+{'+'.join(labels)}", source="<diagnosis>",
                            description=f"{model.name} extended by diagnosis: {what}")


def _check(model: FrameModel, data: ModalData) -> None:
    data_model = data.model
    if not data.is_for(model) and not data_model.endswith((f"{model.name}.json", f"{model.name}.model.json")):
        raise DataFileError(f"{data.source}: the data are for model {data_model!r}, not {model.name!r} "
                            "(pass the data's own model, or data measured on this one)")
    data.check_model(model)
    if data.n_modes < MIN_MODES:
        raise DataFileError(f"{data.source}: {data.n_modes} mode(s) are too few to say anything: "
                            f"a diagnosis needs at least {MIN_MODES}")
