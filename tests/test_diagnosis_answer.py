"""The answer of a diagnosis as the best class of the evidence table (answer.py, core.score_classes).

Every truth is built apart from the candidate code: the model file edited (a rubber rod to a
grounded node and a lumped mass with rotary inertia; a member's section made less deep; members'
section inertia made smaller), the data synthesised from it with the default noise.

- The rows of the evidence table are scored on one set of measured modes, those that pair with
  the calibrated model, even when the local search's model pairs a mode the calibrated model does
  not (a spring to ground brings the suspension mode): every row's log evidence is at most its
  chi^2 drop on those modes over 2 D (the Laplace factor of a bounded prior is at most 1), and the
  row of the several causes lies among the others (it was 15,900 against 311 for the next).
- A member 3.5 % thinner at the base: no local candidate passes the significance test, the
  calibrated model does not fit within the noise, and the member's depth class fits and has the
  most evidence: it is the answer, with its extended model, held-out gain and verdict. At 2 % it
  has too little evidence over no effect, and the answer stays none, NOT ADEQUATE.
- Three separated members with less bending stiffness: "every member" sparse localises exactly
  them and is the answer, with its extended model, held-out prediction and verdict.
"""

import numpy as np
import pytest
from scipy.stats import chi2 as chi2_dist

import fe_problem as fp
from diagnosis_cases import HFRAME, soft_support_truth, thinner_truth
from fe_problem.assembly import AffineModel
from fe_problem.diagnosis.candidates import solve
from fe_problem.diagnosis.evidence import FACTOR_10
from fe_problem.diagnosis.fit import profiled
from fe_problem.diagnosis.residuals import Observations

FREQ_NOISE, SHAPE_NOISE = 0.002, 0.02


def _data(truth, seed):
    return fp.synthetic_measurement(truth, 8, dofs=HFRAME.measured_dofs, freq_noise=FREQ_NOISE,
                                    shape_noise=SHAPE_NOISE, seed=seed, model_name="hframe")


def _chi2(model, data, modes=None):
    """The profiled chi^2 of `model` (its own modes, no candidate) on the measured `modes` (0-based)."""
    hz, sh = solve(AffineModel(model), np.zeros((1, 0)), data.dofs, 14)
    return profiled(Observations.of(data, modes=modes, freq_noise=FREQ_NOISE, shape_noise=SHAPE_NOISE), hz[0], sh[0])


def test_every_row_is_scored_on_the_modes_the_calibrated_model_pairs():
    """The H-frame hung at node 9 on a rubber rod (2e4 N/m) and 30 g at node 4: measured mode 1 is
    the suspension mode, which pairs with no mode of the calibrated model and with a mode of the
    extended one. The local search names the spring and the mass (several causes); their row is
    scored on modes 2-8 like every other row."""
    truth = fp.add_mass(soft_support_truth(9, "x", 2e4), 4, 0.03, inertia_kg_m2=0.03 * 0.02**2 / 6.0)
    data = _data(truth, 41)
    diag = fp.diagnose(HFRAME, data)
    assert diag.residuals.unpaired_modes == (1,)
    assert _chi2(diag.extended_model, data).pairing[0] >= 0  # the extended model pairs mode 1
    assert sorted((c.kind, c.location.get("node")) for c in diag.causes) == [("added_mass", 4),
                                                                            ("boundary_stiffness", 9)]
    rows = diag.evidence.classes
    several = next(c for c in rows if c.family == "several")
    none = next(c for c in rows if c.family == "none")
    paired = np.arange(1, 8)  # modes 2-8
    assert none.chi2 == pytest.approx(_chi2(HFRAME, data, paired).chi2, rel=1e-9)
    # the several causes' sizes refitted on modes 2-8 can only lower the extended model's chi^2 there
    extended_chi2 = _chi2(diag.extended_model, data, paired).chi2
    assert several.chi2 <= extended_chi2 + 1e-6 and several.chi2 > 0.8 * extended_chi2
    d = diag.evidence.dispersion
    for c in rows:  # log Z = -(chi^2 - chi^2_none) / 2D + a Laplace factor <= 0: one set of data for all
        assert c.log_evidence <= (none.chi2 - c.chi2) / (2 * d) + 1e-9, c.label
    others = [c.log_evidence for c in rows if c is not several]
    assert max(others) < several.log_evidence < 1.5 * max(others)
    assert diag.answer.family == "several" and diag.answer.label == several.label


def test_a_thinner_member_no_local_candidate_explains_is_answered_by_its_depth():
    """Element 1 (the base of the left column) 3.5 % less deep (area x 0.965, inertia x 0.965^3, in
    the model file): no local candidate passes the test, but the calibrated model misses the data
    beyond the noise; `member_depth@element=1(thinner)` fits within it, with the most evidence, more
    than ln 10 above every other answer: it is the answer, decisively. (Its held-out prediction is
    reported as it is: the calibrated model, refitted without modes 7-8, predicts them better.)"""
    data = _data(thinner_truth(HFRAME, 1, 0.965), 658136741)
    diag = fp.diagnose(HFRAME, data)
    sel, res = diag.selection, diag.residuals
    assert sel.p_adjusted >= sel.alpha  # the significance test finds nothing
    assert chi2_dist.sf(res.chi2, res.n_residuals - 8 - 1) < sel.alpha  # the calibrated model misfits
    best = diag.evidence.classes[0]
    assert best.label == "member_depth@element=1(thinner)" and best.log_evidence >= FACTOR_10
    assert best.estimate["depth_factor"] == pytest.approx(0.965, abs=0.01)
    a = diag.answer
    assert (a.label, a.family, a.kind, a.location, a.decisive) == (best.label, "model_form", "member_depth",
                                                                   {"element": 1}, True)
    assert a.log_evidence - a.runner_up["log_evidence"] >= FACTOR_10
    assert (diag.cause.kind, diag.cause.location, diag.cause.label) == ("member_depth", {"element": 1}, best.label)
    assert diag.causes == ()  # the local search did not run: nothing was significant
    assert diag.adequate and best.label in diag.verdict.explanation
    ext = diag.extended_model
    assert ext.sections[ext.element(1).section].area_m2 / HFRAME.sections["bar"].area_m2 == pytest.approx(
        diag.cause.estimate["depth_factor"], rel=1e-9)
    assert diag.gain.after is not None and diag.gain.after.mean_abs_error_pct == pytest.approx(
        best.held_out_error_pct, rel=1e-9)
    assert any(w.startswith("no local candidate is significant") and best.label in w for w in diag.warnings)
    record = diag.to_dict()
    assert record["cause"]["kind"] == "member_depth" and record["answer"]["family"] == "model_form"
    from femu.cli.diagnose import summary_text

    text = summary_text(diag, "thin.json", "hframe")
    assert "CAUSE: member_depth at element 1: depth_factor 0.96" in text
    assert "no local candidate is significant: the local search named nothing" in text
    assert "Causes the local search found" not in text  # no empty list of the local search's causes


def test_a_thinner_member_with_too_little_evidence_stays_none_not_adequate():
    """The same member 2.2 % less deep: the depth class has some evidence over no effect, but less
    than ln 10; the answer stays none and the calibrated model's misfit is reported. (2 % less
    deep was the case until the rows were charged for their labels, the side "thinner" among them,
    ln 2: its depth row fell to -0.21, below no effect, and no longer tested this. At 2.2 % it is
    0.58, and at 2.6 % 2.38, the answer.)"""
    data = _data(thinner_truth(HFRAME, 1, 0.978), 658136741)
    diag = fp.diagnose(HFRAME, data)
    assert diag.cause.kind == "none" and diag.answer.family == "none" and diag.extended_model is None
    assert diag.adequate is False
    form = next(c for c in diag.evidence.classes if c.label == "member_depth@element=1(thinner)")
    assert 0 < form.log_evidence < FACTOR_10


def test_three_separated_weaker_members_are_answered_by_the_sparse_class():
    """Elements 2, 6 and 11 (no two share a node) with their section inertia times 0.8, 0.75 and
    0.8 in the model file (their bending stiffness alone): the local search names two stiffness
    gains elsewhere; "every member" sparse localises exactly the three, decisively the best class,
    and is the answer: its cause, extended model (each member's modulus by its ratio), held-out
    prediction and verdict. The local search's causes stay in `causes`."""
    from diagnosis_cases import stiffer_truth

    truth = HFRAME
    for e, f in ((2, 0.8), (6, 0.75), (11, 0.8)):
        truth = stiffer_truth(truth, e, f)
    data = _data(truth, 4)
    diag = fp.diagnose(HFRAME, data)
    best = diag.evidence.classes[0]
    assert best.family == "sparse" and best.label == "every_member_sparse@members=2+6+11"
    ratios = best.estimate["modulus_ratio"]
    assert all(0.65 < r < 0.95 for r in ratios), ratios  # bending 0.75-0.8, read as a modulus
    a = diag.answer
    assert (a.label, a.family, a.kind, a.location, a.decisive) == (best.label, "sparse", "every_member_sparse",
                                                                   {"members": [2, 6, 11]}, True)
    assert a.log_evidence - a.runner_up["log_evidence"] >= FACTOR_10
    assert (diag.cause.kind, diag.cause.location, diag.cause.label) == (a.kind, a.location, a.label)
    assert diag.cause.estimate["modulus_ratio"] == pytest.approx(ratios, rel=1e-12)
    assert diag.causes and all(c.kind != "every_member_sparse" for c in diag.causes)
    ext = diag.extended_model
    for e, r in zip((2, 6, 11), ratios):  # against an unchanged column element of the same section
        assert ext.element_modulus_pa(e) / ext.element_modulus_pa(3) == pytest.approx(r, rel=1e-9)
    assert diag.adequate and best.label in diag.verdict.explanation
    assert diag.verdict.chi2 == pytest.approx(best.chi2, rel=1e-9)
    assert diag.gain.after is not None and diag.gain.after.mean_abs_error_pct == pytest.approx(
        best.held_out_error_pct, rel=1e-9)
    assert diag.gain.after.mean_abs_error_pct < diag.gain.before.mean_abs_error_pct
    assert _chi2(ext, data).chi2 == pytest.approx(best.chi2, rel=1e-6)


def _row(label, family, members=None, ratios=None):
    from fe_problem.diagnosis.evidence import ScoredClass

    est = None if members is None else {"members": members, "modulus_ratio": ratios}
    return ScoredClass(label, family, 1 if members is None else len(members), 10.0, 1.0, est)


def test_one_answer_keeps_a_loss_apart_from_a_gain_and_other_members_apart():
    """`same_answer` (answer.py): classes are one answer when they change the same members'
    stiffness the same way. A loss is never a gain, other members are other members, and a
    member's modulus ratio of exactly 1 is no change (it counted as a gain: a sparse fit with
    member 9 at 1.0 was another answer than element 2's loss, and the same as element 9's gain)."""
    from fe_problem.diagnosis.answer import members_changed, same_answer

    loss2 = _row("stiffness_loss@element=2", "local")
    gain2 = _row("stiffness_gain@element=2", "local")
    zone2 = _row("stiffness_loss@element=2(weak_zone at 0.3 of its length)", "local")
    both = _row("stiffness_loss@element=2 + stiffness_loss@element=9", "several")
    assert members_changed(loss2) == {(2, -1)} and members_changed(gain2) == {(2, 1)}
    assert same_answer(loss2, zone2) and not same_answer(loss2, gain2)
    assert same_answer(loss2, _row("every_member_sparse@members=2", "sparse", [2], [0.8]))
    assert not same_answer(loss2, _row("every_member_sparse@members=2", "sparse", [2], [1.2]))
    assert same_answer(gain2, _row("every_member_sparse@members=2", "sparse", [2], [1.2]))
    assert not same_answer(loss2, _row("every_member_sparse@members=3", "sparse", [3], [0.8]))
    pair = _row("adjacent_members_free@members=2+9", "distributed", [2, 9], [0.85, 0.75])
    assert same_answer(both, pair) and not same_answer(loss2, pair)
    assert not same_answer(both, _row("adjacent_members_free@members=2+9", "distributed", [2, 9], [0.85, 1.1]))
    assert not same_answer(both, _row("adjacent_members_free@members=2+3", "distributed", [2, 3], [0.85, 0.75]))
    # a ratio of exactly 1: no change
    unchanged9 = _row("every_member_sparse@members=2+9", "sparse", [2, 9], [0.8, 1.0])
    assert members_changed(unchanged9) == {(2, -1)} and same_answer(loss2, unchanged9)
    assert not same_answer(_row("stiffness_gain@element=9", "local"),
                           _row("every_member_sparse@members=9", "sparse", [9], [1.0]))
    assert members_changed(_row("every_member_sparse@members=9", "sparse", [9], [1.0])) is None
    assert members_changed(_row("member_depth@element=2", "model_form")) is None
