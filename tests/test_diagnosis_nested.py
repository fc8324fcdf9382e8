"""Evidence by nested sampling (fe_problem/diagnosis/nested.py, `femu diagnose --evidence nested`).

- dynesty's log Z against the closed form of a linear-Gaussian model (1 and 2 parameters, a
  posterior cut by the prior's bound), within 3 of its own error estimates; the same seed gives
  the same numbers.
- On a real one-parameter class (a member's uniform loss on synthetic data of a frame whose
  member was made softer in its section, not by the candidate code): nested sampling agrees
  with numerical integration (scipy quad) within its error, and the Laplace value agrees with the
  nested one within dynesty's error plus the Laplace approximation's own error (against quad).
- A free group class (two adjacent members free: H-frame elements 9 and 10 at 0.85 and 0.75,
  moduli in the model file) is sampled too under `fp.diagnose(evidence="nested")`: nested
  sampling agrees with a grid integral of the real chi^2 within its error, and the Laplace value
  with the nested one within dynesty's error plus Laplace's own error (against the grid).
- The CLI: --evidence nested gives the table with each sampled row's error; a missing dynesty is
  one line and exit 2; a bad --evidence is refused.
"""

import sys

import numpy as np
import pytest
from scipy import integrate
from scipy.stats import norm

pytest.importorskip("dynesty")  # the test extra installs it

import fe_problem as fp
from diagnosis_cases import HFRAME, Case, diagnose_through_cli, stiffer_truth
from fe_problem.diagnosis.candidates import all_candidates
from fe_problem.diagnosis.core import calibrate
from fe_problem.diagnosis.evidence import occam_log_factor
from fe_problem.diagnosis.fit import chi2_batch, fit
from fe_problem.diagnosis.nested import log_evidence, seed_of
from femu.cli import main


def _closed_1d(mu, s, lo, hi, d):
    sd = s * np.sqrt(d)
    return np.log(sd * np.sqrt(2 * np.pi) * (norm.cdf((hi - mu) / sd) - norm.cdf((lo - mu) / sd)) / (hi - lo))


@pytest.mark.parametrize("mu, s, upper, d", [(0.3, 0.05, 1.0, 1.0), (0.02, 0.05, 1.0, 2.0)])
def test_nested_matches_the_closed_form_in_one_dimension(mu, s, upper, d):
    lz, err, ncall = log_evidence(lambda a: ((a[0] - mu) / s) ** 2, 0.0, upper, 0.0, d, seed=7)
    assert 0 < err < 0.3 and ncall > 100
    assert abs(lz - _closed_1d(mu, s, 0.0, upper, d)) < 3 * err


def test_nested_matches_the_closed_form_in_two_dimensions_and_is_reproducible():
    lo, hi = np.array([0.0, -0.9]), np.array([1.0, 3.0])

    def chi2(a):
        return ((a[0] - 0.3) / 0.05) ** 2 + ((a[1] + 0.2) / 0.1) ** 2

    lz, err, _ = log_evidence(chi2, lo, hi, 0.0, 1.0, seed=11)
    closed = _closed_1d(0.3, 0.05, 0.0, 1.0, 1.0) + _closed_1d(-0.2, 0.1, -0.9, 3.0, 1.0)
    assert abs(lz - closed) < 3 * err
    assert log_evidence(chi2, lo, hi, 0.0, 1.0, seed=11)[:2] == (lz, err)
    assert seed_of("a") == seed_of("a") != seed_of("b")


def test_laplace_and_nested_agree_on_a_one_parameter_class():
    truth = stiffer_truth(HFRAME, 2, 0.75)  # the member's section inertia edited in the model file
    data = fp.synthetic_measurement(truth, 8, dofs=HFRAME.measured_dofs, freq_noise=0.002, shape_noise=0.02, seed=1,
                                    model_name="hframe")
    cal = calibrate(HFRAME, data, 0.002, 0.02)
    cand = next(c for c in all_candidates(cal.setting, ["stiffness_loss"])
                if c.location == {"element": 2} and c.meta.get("profile") == "uniform")
    f = fit(cal.obs, cand)
    assert 0.15 < f.a < 0.35

    def chi2_at(a):
        return np.array([x.chi2 for x in chi2_batch(cal.obs, cand, np.atleast_1d(np.asarray(a, dtype=float)))])

    laplace = -(f.chi2 - cal.base.chi2) / 2 + occam_log_factor(chi2_at, f.a, cand.upper)
    lz, err, _ = log_evidence(lambda a: chi2_at(a[:1])[0], 0.0, cand.upper, cal.base.chi2, 1.0, seed=3)
    val, _ = integrate.quad(lambda a: np.exp(-(chi2_at([a])[0] - f.chi2) / 2), 0.0, cand.upper, points=[f.a],
                            limit=200, epsabs=0.0, epsrel=1e-7)
    quad = -(f.chi2 - cal.base.chi2) / 2 + np.log(val / cand.upper)
    assert abs(lz - quad) < 3 * err
    assert abs(laplace - lz) < 3 * err + abs(laplace - quad)
    assert abs(laplace - quad) < 0.2  # near-Gaussian: the Laplace approximation's error is small here


def test_a_free_group_class_is_sampled_and_agrees_with_laplace():
    from fe_problem.diagnosis.group_free import fit_pair
    from test_diagnosis_spread import _hframe_data

    data = _hframe_data({9: 0.85, 10: 0.75}, 1)  # moduli edited in the model file
    laplace = {c.label: c for c in fp.diagnose(HFRAME, data).evidence.classes}
    nested = fp.diagnose(HFRAME, data, evidence="nested").evidence
    row = next(c for c in nested.classes if c.label.startswith("adjacent_members_free@"))
    assert row.label == "adjacent_members_free@members=9+10" and row.method == "nested", row
    assert row.n_parameters == 2 and 0 < row.log_evidence_error < 1
    assert 1 <= sum(c.method == "nested" for c in nested.classes) <= 6
    # the same integral on a 61 x 61 grid over +-6 sd of each ratio (cut to its prior, [0.1, 1])
    cal = calibrate(HFRAME, data, 0.002, 0.02)
    g = fit_pair(cal.setting, cal.obs, cal.base.pairing, [9, 10])
    assert g.label == row.label and g.fit.chi2 == pytest.approx(row.chi2, rel=1e-9)
    d, (lo, hi) = nested.dispersion, g.prior()
    sd = g.fit.theta_std * np.sqrt(d)
    axes = [np.linspace(max(lo[k], t - 6 * sd[k]), min(hi[k], t + 6 * sd[k]), 61) for k, t in enumerate(g.fit.theta)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 2)
    chi2 = np.array([f.chi2 for f in g.params.residuals(cal.obs, grid)]).reshape(61, 61)
    top = -(chi2.min() - cal.base.chi2) / (2 * d)
    w = np.exp(-(chi2 - chi2.min()) / (2 * d))
    integral = top + np.log(np.trapezoid(np.trapezoid(w, axes[1], axis=1), axes[0]) / np.prod(hi - lo))
    integral += 2 * np.log(0.5)  # each member's side, a loss or a gain: prior weight 1/2 each
    lap = laplace[row.label].log_evidence
    assert abs(row.log_evidence - integral) < 3 * row.log_evidence_error
    assert abs(lap - integral) < 0.5  # near-Gaussian: Laplace is accurate on this class
    # docs/diagnosis-forms.md: "326.16 +- 0.23 against 325.80 (D = 1": this row, dynesty's error, Laplace's
    import re
    from pathlib import Path

    page = " ".join((Path(__file__).resolve().parents[1] / "docs" / "diagnosis-forms.md").read_text().split())
    said = re.search(r"two adjacent members free on the H-frame \(9, 10 at 0.85/0.75, seed 1\): .{0,60}?"
                     r"([\d.]+) \+- ([\d.]+) against ([\d.]+) \(D = (\d+);", page)
    assert said, "docs/diagnosis-forms.md: the nested row of the pair not found"
    assert said.groups() == (f"{row.log_evidence:.2f}", f"{row.log_evidence_error:.2f}", f"{lap:.2f}", f"{d:g}")


def test_cli_nested_gives_the_table_with_errors(tmp_path):
    truth = stiffer_truth(HFRAME, 2, 0.75)
    record = diagnose_through_cli(Case("stiffness_loss", {"element": 2}, 0.0, truth, 1), tmp_path,
                                  extra=["--evidence", "nested"])
    ev = record["evidence"]
    assert ev["method"] == "nested"
    sampled = [c for c in ev["classes"] if c["method"] == "nested"]
    assert 1 <= len(sampled) <= 6 and all(0 < c["log_evidence_error"] < 1 for c in sampled)
    assert [c["log_evidence"] for c in ev["classes"]] == sorted((c["log_evidence"] for c in ev["classes"]),
                                                                reverse=True)
    best = ev["classes"][0]
    assert best["method"] == "nested" and "element=2" in best["label"]
    none = next(c for c in ev["classes"] if c["family"] == "none")
    assert none["log_evidence"] == 0.0 and none["method"] == "exact"


def test_cli_without_dynesty_is_one_line_and_exit_2(tmp_path, capsys, monkeypatch):
    path = tmp_path / "d.json"
    fp.save_modal_data(fp.synthetic_measurement(HFRAME, 8, dofs=HFRAME.measured_dofs, seed=1, model_name="hframe"),
                       path)
    monkeypatch.setitem(sys.modules, "dynesty", None)  # as if not installed
    assert main(["diagnose", str(path), "--evidence", "nested"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "dynesty" in err[0] and "femu-bench[nested]" in err[0]
    with pytest.raises(SystemExit) as exc:
        main(["diagnose", str(path), "--evidence", "bayes"])
    assert exc.value.code == 2
    with pytest.raises(ValueError, match="evidence must be one of laplace, nested"):
        fp.diagnose(None, path, evidence="bayes")


def test_the_text_table_shows_dynesty_s_error_and_which_rows_are_laplace():
    from types import SimpleNamespace

    from fe_problem.diagnosis.evidence import ScoredClass, ranked
    from femu.reports.diagnosis_text import evidence_lines

    ev = ranked([ScoredClass("calibrated model (no effect)", "none", 0, 20.0, 0.0, log_evidence_error=0.0,
                             method="exact"),
                 ScoredClass("stiffness_loss@element=2", "local", 1, 10.0, 5.0, log_evidence_error=0.123,
                             method="nested"),
                 ScoredClass("a + b", "several", 2, 9.0, 4.0)], "nested", 1.0)
    lines = evidence_lines(SimpleNamespace(evidence=ev))
    assert "nested" in lines[0] and "Laplace" in lines[0] and "+- error" in lines[1]
    rows = {line.split()[0]: line.split() for line in lines[2:5]}
    assert rows["stiffness_loss@element=2"][5] == "0.12"
    assert rows["a"][7] == "-"  # the several-cause row: Laplace, no error
    assert "within a factor of 10" in lines[5]
