"""The suite's version: its definitions' fingerprint is the current version's, so that any change
of a problem's data, bounds or f_opt comes with a new version (fe_problem.suite.SUITE_VERSION)."""

import pytest

from fe_problem import suite


@pytest.fixture(scope="module")
def fingerprint():
    return suite.suite_fingerprint()


def test_the_definitions_are_the_current_versions(fingerprint):
    assert fingerprint == suite.SUITE_FINGERPRINTS[suite.SUITE_VERSION], (
        "a suite problem's definition (data, bounds, f_opt, ...) changed: add a new SUITE_VERSION with its "
        f"fingerprint {fingerprint} to SUITE_FINGERPRINTS (never edit an earlier line)")
    # every version has its own definitions
    assert len(set(suite.SUITE_FINGERPRINTS.values())) == len(suite.SUITE_FINGERPRINTS)
    assert list(suite.SUITE_FINGERPRINTS)[-1] == suite.SUITE_VERSION


def test_a_changed_f_opt_bound_or_data_changes_the_fingerprint(fingerprint, monkeypatch):
    d = suite.suite_definition()
    assert set(d["problems"]) == set(suite.suite_ids())
    # f_opt: a certificate moved by one part in 1e6
    certs = {k: dict(v) for k, v in suite.certificates().items()}
    pid = next(k for k, v in certs.items() if v["f_opt"] > 0)
    certs[pid]["f_opt"] *= 1 + 1e-6
    with monkeypatch.context() as m:
        m.setattr(suite, "certificates", lambda: certs)
        assert suite.suite_fingerprint() != fingerprint
    # a bound
    with monkeypatch.context() as m:
        m.setattr(suite, "STEEL_BOUNDS", (0.8 * 2.1e11, 1.15 * 2.1e11))
        suite._structure.cache_clear()
        assert suite.suite_fingerprint() != fingerprint
    suite._structure.cache_clear()
    # the data of one instance
    real = suite._truth_and_data

    def shifted(problem_id):
        truth, data = real(problem_id)
        if problem_id != "frame-shape/12/1":
            return truth, data
        return truth, type(data)(data.model, data.dofs, data.frequencies_hz * (1 + 1e-7), data.shapes, data.meta)

    with monkeypatch.context() as m:
        m.setattr(suite, "_truth_and_data", shifted)
        assert suite.suite_fingerprint() != fingerprint
    assert suite.suite_fingerprint() == fingerprint  # and back
