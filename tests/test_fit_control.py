"""The fit control's shortcut in the further-cause rounds (`rounds._listed`: the first round's
candidates reused) against the computation it replaces: on the cracked 2 x 8 frame of
tests/test_reduced_basis.py (sparse path; the data hide a crack built as a rotational spring
inside an element, not by any candidate), the reused candidate's fit against a fresh one's and
the listing kept to its own setting and thread; on the H-frame with two hidden effects (a crack
and a lumped mass, built as in tests/diagnosis_cases.py), the user's record with and without
the listing. A distributed class's fit on its spread basis against its full fit:
tests/test_reduced_basis.py."""

import contextlib
import threading

import numpy as np
import pytest

import fe_problem as fp
from diagnosis_cases import cases
from fe_problem.diagnosis import picks, rounds
from fe_problem.diagnosis.kinds import CandidateKey
from fe_problem.diagnosis.candidates import Setting, all_candidates
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
    key = listed[label].key
    fresh = rounds._candidate_on(model, st, key)
    assert fresh is not listed[label]
    with rounds._listed(st, cands):
        first = fit(cal.obs, listed[label])
        again = rounds._candidate_on(model, st, key)
        assert again is listed[label]
        zone = next(c.label for c in cands if "(zone" in c.label)
        assert rounds._candidate_on(model, st, listed[zone].key) is not listed[zone]
        other = model.replace(name="copy")
        assert rounds._candidate_on(other, st, key) is not listed[label]
        got = fit(cal.obs, again, first.a)
    assert rounds._LISTED.get() is None
    want = fit(cal.obs, fresh, first.a)
    assert (got.a, got.s, got.chi2) == (want.a, want.s, want.chi2)
    assert np.array_equal(got.residuals, want.residuals) and np.array_equal(got.pairing, want.pairing)


def _modes_and_coords(c):
    """How many modes and measured coordinates candidate `c`'s own forward gives (at a = 0)."""
    hz, sh = c.forward(np.zeros(1))
    return hz.shape[1], sh.shape[1]


def test_the_listing_serves_only_its_own_setting_and_thread(case):
    """Two diagnoses of the same model object with different data (other coordinates, fewer
    modes), each in its own thread with its first round listed: each is given its own
    candidates, with its own coordinates and mode count; a setting that differs from the
    listed one on the same model (in the same thread) gets a candidate built afresh in it."""
    cal, cands = case
    st1 = cal.setting
    model = st1.model
    st2 = Setting(model, st1.coords[:-3], st1.n_modes - 2)
    label = "stiffness_loss@element=20"
    key = CandidateKey.of("stiffness_loss", {"element": 20})
    first1 = next(c for c in cands if c.label == label)
    first2 = rounds._candidate_on(model, st2, key)  # the second diagnosis's first round
    assert _modes_and_coords(first1) == (st1.n_modes, len(st1.coords))
    assert _modes_and_coords(first2) == (st2.n_modes, len(st2.coords))

    both_listed = threading.Barrier(2, timeout=60)
    got = {}

    def diagnosis(name, st, first):
        with rounds._listed(st, [first]):
            both_listed.wait()  # the other thread's first round is listed now too
            got[name] = rounds._candidate_on(model, st, key)
            both_listed.wait()

    threads = [threading.Thread(target=diagnosis, args=a) for a in (("one", st1, first1), ("two", st2, first2))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert got["one"] is first1 and got["two"] is first2

    with rounds._listed(st1, cands):
        other = rounds._candidate_on(model, st2, key)
        assert rounds._candidate_on(model, st1, key) is first1
    assert other is not first1 and other is not first2
    assert _modes_and_coords(other) == (st2.n_modes, len(st2.coords))


def test_a_two_cause_diagnosis_is_the_same_with_and_without_the_listing(monkeypatch):
    """What the user sees: `fp.diagnose` of the H-frame (dense path) with a crack and a lumped
    mass hidden in its data gives the same record (`Diagnosis.to_dict()`) with the first round's
    candidates listed during the rounds as with every candidate built afresh, and the listing
    was used (the rounds asked it for candidates it had)."""
    case = cases(seed=7, plan={"two_effects": 1})[0]
    data = case.data("hframe")
    served = []
    listed_candidate = picks._listed_candidate

    def counting(*args):
        c = listed_candidate(*args)
        served.append(c is not None)
        return c

    monkeypatch.setattr(picks, "_listed_candidate", counting)
    with_listing = fp.diagnose("hframe", data).to_dict()
    assert any(served), "the rounds never asked the listing for a first-round candidate"
    monkeypatch.setattr(rounds, "_listed", lambda *args: contextlib.nullcontext())
    served.clear()
    without = fp.diagnose("hframe", data).to_dict()
    assert not any(served)
    assert len(with_listing["causes"]) >= 2, with_listing["causes"]
    assert with_listing == without
