"""The fit control's shortcuts (fe_problem/diagnosis/rounds.py) against the computation each replaces,
on the cracked 2 x 8 frame of tests/test_reduced_basis.py (sparse path; the data hide a crack built
as a rotational spring inside an element, not by any candidate). A distributed class's fit on its
spread basis against its full fit: tests/test_reduced_basis.py."""

import numpy as np
import pytest

from fe_problem.diagnosis import rounds
from fe_problem.diagnosis.candidates import all_candidates
from fe_problem.diagnosis.fit import fit

from test_reduced_basis import cracked_calibration


@pytest.fixture(scope="module")
def case():
    cal = cracked_calibration()
    return cal, all_candidates(cal.setting)


@pytest.mark.parametrize("label", ["stiffness_loss@element=20", "joint_flexibility@node=14,element=20",
                                   "added_mass@node=30"])
def test_a_first_round_candidate_asked_again_on_its_model_is_the_one_built_afresh(case, label):
    """While the rounds run (`rounds._listed`), a candidate asked for by its label on the model
    the first round was built on is that round's own object (its solved sizes and its shared
    basis kept), and its fit (the first round's a as the hint, as `_joint_refit` and `_finish`
    refit it) is the fit of the candidate built afresh, bit for bit; a weak zone's label and
    any other model are built afresh, and the list is gone after the rounds."""
    cal, cands = case
    st, model = cal.setting, cal.setting.model
    listed = {c.label: c for c in cands}
    assert label in listed, sorted(k for k in listed if k.startswith(label.split("@")[0]))[:5]
    kind = label.split("@")[0]
    fresh = rounds._candidate_on(model, st, kind, label)
    assert fresh is not listed[label]
    with rounds._listed(model, cands):
        first = fit(cal.obs, listed[label])
        again = rounds._candidate_on(model, st, kind, label)
        assert again is listed[label]
        zone = next(c.label for c in cands if "(zone" in c.label)
        assert rounds._candidate_on(model, st, "stiffness_loss", zone) is not listed[zone]
        other = model.replace(name="copy")
        assert rounds._candidate_on(other, st, kind, label) is not listed[label]
        got = fit(cal.obs, again, first.a)
    assert not rounds._LISTED
    want = fit(cal.obs, fresh, first.a)
    assert (got.a, got.s, got.chi2) == (want.a, want.s, want.chi2)
    assert np.array_equal(got.residuals, want.residuals) and np.array_equal(got.pairing, want.pairing)
