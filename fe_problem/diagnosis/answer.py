"""The answer of a diagnosis: the best model class by evidence, and whether the data decide it.

The likelihood-ratio test answers "is there anything at all" (core.select); when it finds nothing
the answer is the calibrated model (no effect), unless that model does not fit within the noise
and the best class by evidence is a non-local one (none of them is among the test's candidates)
with more than ln 10 of log evidence over no effect that does fit within it: then that class is
the answer (core._beyond_the_test; a member 3.5 % thinner passed no local test). Otherwise the
classes of the evidence table
(evidence.py) compete: the local search's result (one cause, or several: rounds.py, whose own
tests with joint refits choose within the local family), the distributed classes (groups.py),
"every member" sparse (sparse_class.py) and the model-form classes (modelform.py, supports.py).
The answer is the best of them by log evidence; when the best is the local family's, or a class
that changes the same members' stiffness the same way as the local search's result
(`same_answer`: two members as several causes and as two adjacent members free), the answer is
the local search's result.

Decisive: the best class that is a different answer (another family, or another kind or place:
the profiles of one element's loss are one answer; so are classes that soften or stiffen the
same members, `members_changed`) must lie at least ln 10 below the answer in
log evidence (a factor of 10, `evidence.FACTOR_10`); otherwise the answer is still named, marked
not decisive, and the text says which class it cannot be told apart from. (Naming "cannot tell
apart" alone would lose a crack whose thinner-member twin is within 1.6 of it: the crack is the
best, its evidence only not decisive.)

When the answer is not local, its class gives the extended model (the calibrated model with the
class's effect), the held-out prediction (the class refitted without the held-out modes) and the
verdict (its goodness of fit); the local search's causes stay in the record as the local class's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import FrameModel
from . import plausibility, sparse_class
from .setting import Candidate, scale_stiffness
from .evidence import FACTOR_10, Evidence, ScoredClass
from .kinds import CandidateKey, spec_of
from .record import NON_LOCAL, Answer, Cause, Gain, Verdict
from .verdict import verdict

#: The calibrated model's row in the evidence table (core.score_classes).
NONE_LABEL = "calibrated model (no effect)"


def row_keys(c: ScoredClass) -> tuple[CandidateKey, ...]:
    """The keys of a row's candidates (`ScoredClass.keys`); for a row built from a label alone (a
    record read back, a table written by hand: the JSON boundary) the keys its label names; () for
    the calibrated model and a label that names no key."""
    if c.keys or c.family == "none":
        return c.keys
    try:
        return tuple(CandidateKey.parse(part) for part in c.label.split(" + "))
    except ValueError:
        return ()


def place_label(c: ScoredClass) -> str:
    """The answer a row names: its candidate's kind and place (`CandidateKey.place`: the profiles
    of one element's loss, a member thinner or deeper, are one answer); the label itself for the
    calibrated model, several causes and a class named by no key."""
    keys = row_keys(c) if c.family not in ("none", "several") else ()
    return keys[0].place.label() if len(keys) == 1 else c.label


def answer_key(c: ScoredClass) -> tuple[str, str]:
    """(family, kind@place) of a class: classes with one key are one answer (the profiles of one
    element's loss, a member thinner or deeper); several causes are one answer as a whole."""
    return c.family, place_label(c)


def members_changed(c: ScoredClass) -> frozenset | None:
    """The members whose stiffness a class changes, each with the sign of its change ((element,
    -1) softer, (element, +1) stiffer), when the class is nothing but such changes: a local
    stiffness loss or gain (uniform or a weak zone: profiles of one element's loss), several of
    them, the sparse class, two adjacent members free. A modulus ratio of exactly 1 is no change
    (the member left out). Else None, also when no member is changed."""
    if c.family in ("local", "several"):
        out = set()
        keys = row_keys(c)
        for key in keys:
            spec, element = spec_of(key), key.get("element")
            if (spec is None or spec.sides != "stiffness" or len(key.where or ()) != 1
                    or not isinstance(element, int) or element < 0):
                return None
            out.add((element, spec.side))
        return frozenset(out) if keys else None
    est = c.estimate or {}
    if c.family in ("sparse", "distributed") and "modulus_ratio" in est and isinstance(est["modulus_ratio"], list):
        out = frozenset((int(e), -1 if r < 1.0 else 1) for e, r in zip(est["members"], est["modulus_ratio"])
                        if r != 1.0)
        return out or None
    return None


def same_answer(a: ScoredClass, b: ScoredClass) -> bool:
    """Whether two classes are one answer: one key (`answer_key`), or the same members' stiffness
    changed the same way (`members_changed`: a member's loss found by the local search and by the
    sparse class, two members as several causes and as two adjacent members free)."""
    if answer_key(a) == answer_key(b):
        return True
    ma, mb = members_changed(a), members_changed(b)
    return ma is not None and ma == mb


def search_key(rounds) -> tuple[str, str]:
    """The key of the local search's result: none (`rounds` None), its one cause, or several."""
    if rounds is None:
        return "none", NONE_LABEL
    if len(rounds.sized) > 1:
        return "several", " + ".join(c.label for c, _ in rounds.sized)
    return "local", rounds.sized[0][0].key.place.label()


def residual_dof(row: ScoredClass, obs) -> int:
    """The residual degrees of freedom a class rests on: the data's count (every frequency, every
    shape entry less one per shape: its scale is free) less its fitted parameters, the global
    scale included (not clipped at 1, as `Observations.dof` is for the chi^2 test)."""
    return obs.n_residuals - obs.n_shape_modes - 1 - row.n_parameters


def dof_note(row: ScoredClass, obs) -> str | None:
    """The sentence when the answer (not the calibrated model) rests on fewer residual degrees of
    freedom than a decisive answer needs (`plausibility.MIN_DOF`), else None."""
    if row is None or row.family == "none":
        return None
    dof = residual_dof(row, obs)
    if dof >= plausibility.MIN_DOF:
        return None
    return (f"{row.label} rests on {dof} residual degree(s) of freedom ({obs.n_residuals - obs.n_shape_modes} data "
            f"less {1 + row.n_parameters} fitted parameters, the global scale included), fewer than the "
            f"{plausibility.MIN_DOF} a decisive answer needs: more modes or measured shapes are needed")


def choose(ev: Evidence, search: tuple[str, str], significant: bool,
           obs=None) -> tuple[ScoredClass, ScoredClass | None, bool]:
    """(the answer's row, the runner-up's row or None, decisive). The answer is the best class when
    it is non-local and may be the answer (`significant`: the test found something, or it found
    nothing but the calibrated model misfits and that class fits, core._beyond_the_test), else the
    local search's row. `obs` (the observations the classes were fitted to): an answer that rests on
    fewer residual degrees of freedom than `plausibility.MIN_DOF` is never decisive (`dof_note`)."""
    rows = list(ev.classes)
    own = next((c for c in rows if answer_key(c) == search), None)
    best = rows[0] if rows else None
    if own is None or (significant and best is not None and best.family in NON_LOCAL and not same_answer(best, own)):
        own = best  # a non-local class that is the search's answer (the same members changed) leaves it the answer
    if own is None:
        return None, None, True
    runner = next((c for c in rows if not same_answer(c, own)), None)
    decisive = runner is None or own.log_evidence - runner.log_evidence >= FACTOR_10
    if obs is not None and dof_note(own, obs) is not None:
        decisive = False
    return own, runner, decisive


def record(row: ScoredClass, runner: ScoredClass | None, decisive: bool, cause: Cause) -> Answer:
    """The record's `Answer` for the chosen row; kind, location and plausibility from `cause`
    (the answer's cause: the local search's first, or the non-local class's)."""
    estimate = None if row.family == "several" else (cause.estimate or row.estimate)
    up = None if runner is None else {"label": runner.label, "family": runner.family, "estimate": runner.estimate,
                                      "log_evidence": runner.log_evidence}
    label = cause.label if row.family == "local" and cause.label else row.label  # a crack's refined zone
    return Answer(label, row.family, "none" if row.family == "none" else (cause.kind if row.family != "several"
                                                                              else "several"),
                  cause.location if row.family not in ("none", "several") else None, estimate, row.log_evidence,
                  decisive, up, cause.plausible, cause.implausible_because)


def undecided_note(a: Answer) -> str | None:
    """The sentence for an answer that is not decisive, else None."""
    ru = a.runner_up
    if a.decisive or ru is None:
        return None
    if ru["log_evidence"] > a.log_evidence:
        return (f"{ru['label']} has more evidence than {a.label} (log evidence {ru['log_evidence']:.4g} against "
                f"{a.log_evidence:.4g}), but " + ("no candidate is significant" if a.family == "none" else
                                                  "the local search's rounds chose the answer within the local family"))
    return (f"cannot tell apart {a.label} from {ru['label']} (log evidence {a.log_evidence:.4g} against "
            f"{ru['log_evidence']:.4g}, within a factor of 10): the answer is the best class, not a decisive one")


@dataclass(frozen=True, eq=False)
class NonLocal:
    """What a non-local answer's class gives the record: its cause, extended model, held-out gain,
    verdict, and its number of fitted parameters (the global scale included)."""

    cause: Cause
    extended_model: FrameModel
    gain: Gain
    verdict: Verdict
    n_params: int


def non_local(cal, row: ScoredClass, fitted: dict, sparse, p_adjusted: float, alpha: float, user: FrameModel,
              gain_of, search_labels: list[str], groups: dict | None = None, why: str | None = None) -> NonLocal:
    """The answer's class (a Candidate with its fit in `fitted`, label -> (candidate, Fit), the
    sparse class `sparse` or a free group class of `groups`, label -> group_free.GroupFit) as the
    record's cause, extended model, gain and verdict. p_adjusted: the significance test's
    (core.select); gain_of: core.gain; search_labels: the local search's causes; why: the cause's
    explanation (default: the answer is the best class, the local search's causes are in `causes`)."""
    what = f"the best class by evidence, {row.label},"
    found = ", ".join(search_labels) or "none"
    why = why or (f"the answer is the best class by evidence ({row.family}: {row.label}); the local search's "
                  f"cause(s), {found}, are in `causes` (the local class's)")
    groups = groups or {}
    if row.family == "sparse" or row.label in groups:
        if row.family == "sparse":
            am, f = sparse_class._AllMembers(cal.setting), sparse
            cause = Cause(sparse_class.KIND, {"members": list(sparse.members)}, sparse.estimate(), True, p_adjusted,
                          row.label, explanation=why)
        else:
            g = groups[row.label]
            am, f = g.params, g.fit
            cause = Cause(g.kind, g.location, g.estimate(), True, p_adjusted, row.label, explanation=why)
        extended, fit, gain, n = _moduli_class(cal, am, f, gain_of)
    else:
        cand, fit = fitted[row.label]
        extended = scale_stiffness(cand.extend(fit.a), fit.s)
        cause = plausibility.judged(user, Cause(cand.kind, cand.location, cand.estimate(fit.a, fit.s), True, p_adjusted,
                                    row.label, explanation=why))
        gain = gain_of(cal, cand)
        n = 2
    return NonLocal(cause, extended, gain, verdict(cal.obs, fit, n, alpha, what=what), n)


def _moduli_class(cal, am, f, gain_of) -> tuple[FrameModel, object, Gain, int]:
    """A class of element moduli as the answer ("every member" sparse, sparse_class.py; every storey
    free, group_free.py; `am` its parameters, `sparse_class._AllMembers`, `f` its fit,
    `sparse_class.SparseFit`): (the extended model, each element's modulus E0 (1 + its change) (Pa)
    with the class's global scale; the class's fit (`fit.Fit`) to the calibrated model's modes; the
    held-out gain, the class refitted without the held-out modes, no prediction interval: the class
    has no profile of one size; the number of fitted parameters, the global scale included)."""
    st = cal.setting
    theta = np.zeros(len(am.names))
    theta[[am.names.index(x) for x in f.members]] = f.theta
    change = theta if am.weights is None else am.weights @ theta  # each element's relative modulus change
    moduli = {e: float(e0 * (1.0 + c)) for e, e0, c in zip(am.ids, am.e0, change) if c != 0.0}
    extended = scale_stiffness(st.model.with_element_moduli(moduli), f.s)
    fit = am.residuals(cal.obs, theta[None])[0]
    gain = gain_of(cal, None)
    held = sparse_class.held_out(st, cal.data, cal.used, f, cal.obs.freq_noise, cal.obs.shape_noise, am)
    if held is not None:
        gain = Gain(gain.held_out_modes, gain.fit_modes, gain.before, held[0], held[1])
    return extended, fit, gain, 1 + len(f.theta)


def fitted_candidates(fits) -> dict[str, tuple[Candidate, object]]:
    """label -> (candidate, Fit) of the scored classes' fits (core.score_classes)."""
    return {c.label: (c, f) for c, f, _ in fits}

