"""The predictive class choice when nothing fits within the noise (issue 38; predictive.py): the
leave-one-mode-out refit against a plain loop and against exact refits, and the choice on
independent truths whose real noise is 3-10 times the stated one."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal

import fe_problem as fp
from fe_problem.diagnosis import core, group_free, predictive, sparse_class
from fe_problem.diagnosis.fit import fit
from fe_problem.diagnosis.groups import distributed_candidates
from fe_problem.diagnosis.residuals import Observations
from fe_problem.model.generate import regular_frame


# == the algebra against a plain loop ===========================================================
def _plain_loo(r, jac, rows, lower, upper, dispersion):
    """Leave-one-block-out of a linear model r(x) = r + J x (x = 0 the full fit), written out block by
    block: the bounded least-squares refit without the block (scipy's lsq_linear), the block's
    predicted residuals and their Gaussian log density, covariance D (I + J_m (J_R^T J_R)^-1 J_m^T)
    over the free parameters."""
    from scipy.optimize import lsq_linear

    out, errs = [], []
    for m in range(len(rows)):
        own = rows[m][rows[m] >= 0]
        rest = np.setdiff1d(np.arange(len(r)), own)
        x = lsq_linear(jac[rest], -r[rest], bounds=(lower, upper), method="bvls", tol=1e-14).x
        free = (x > lower + 1e-9) & (x < upper - 1e-9)
        pred = r[own] + jac[own] @ x
        jf = jac[:, free]
        cov = dispersion * (np.eye(len(own)) + jf[own] @ np.linalg.inv(jf[rest].T @ jf[rest]) @ jf[own].T)
        out.append(multivariate_normal(np.zeros(len(own)), cov).logpdf(pred))
        errs.append(pred[0])
    return np.array(out), np.array(errs)


@pytest.mark.parametrize("bounded", [False, True])
def test_the_vectorised_refit_matches_a_plain_loop(bounded):
    """On a linear residual model (4 modes, 3 with a 5-entry shape; 2 parameters and log s) the
    vectorised refits and densities equal a block-by-block bounded least-squares refit and scipy's
    multivariate normal density; bounded: the first parameter's unbounded fit beyond its range, so
    that some refits hold it at its bound (here its upper one, in three of the four refits) and others
    not."""
    rng = np.random.default_rng(4)
    shapes = rng.standard_normal((5, 4))
    shapes /= np.linalg.norm(shapes, axis=0)
    shapes[:, 2] = np.nan
    data = fp.ModalData("m", tuple((n, "x") for n in range(1, 6)), np.array([5.0, 9.0, 14.0, 20.0]), shapes)
    obs = Observations.of(data)
    rows = predictive.mode_rows(obs)
    n = obs.n_residuals
    jac = rng.standard_normal((n, 3))
    r = rng.standard_normal(n)
    lower, upper = np.array([-0.3, -1.0]), np.array([0.5, 1.0])
    if bounded:  # the first parameter's unbounded optimum about 0.8 of its own, its range [0, 0.5]
        lower = np.array([0.0, -1.0])
        r = r - jac[:, 1:] @ np.linalg.lstsq(jac[:, 1:], r, rcond=None)[0] - 0.8 * jac[:, 0]
    else:
        r = r - jac @ np.linalg.lstsq(jac, r, rcond=None)[0]  # J^T r = 0: an interior fit
    cm = predictive.ClassModel("c", None, np.zeros(2), 1.0, lower, upper, np.arange(4))
    rows = predictive.mode_rows(obs)
    delta, inv = predictive.refit_steps(obs, cm, np.repeat(r[None], len(rows), 0), jac, np.zeros((len(rows), 3)))
    got = predictive.scored(obs, "c", r, jac, rows, delta, inv, 2.5)
    want, err = _plain_loo(r, jac, rows, np.r_[lower, -np.inf], np.r_[upper, np.inf], 2.5)
    np.testing.assert_allclose(got.elpd_modes, want, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(np.array(got.frequency_error_pct) / (100 * obs.freq_noise), err, rtol=1e-8, atol=1e-8)
    if bounded:
        held = np.isclose(delta[:, 0], upper[0])
        assert held.any() and not held.all()  # held at the bound in some refits, free in others


# == the first-order refit against exact refits ==================================================
def four_storeys(times: float, seed: int):
    """A one-bay four-storey frame measured in x at its floors, 4 modes; the truth its storeys' moduli
    0.7, 0.8, 0.9 and 1 of nominal set directly in the elements (test_diagnosis_robust.four_storeys);
    real noise `times` the stated 0.2 % / 2 %."""
    model = regular_frame(1, 4, 6.0, 3.0, floor_mass_kg=5000.0, name="four")
    ratio = {1: 0.7, 2: 0.8, 3: 0.9}
    top = {e.id: int(round(max(model.node(e.node_i).y, model.node(e.node_j).y) / 3.0)) for e in model.elements}
    truth = model.with_element_moduli({e: ratio[s] * model.element_modulus_pa(e) for e, s in top.items() if s in ratio})
    dofs = tuple((s * 2 + 1, "x") for s in range(1, 5))
    return model, fp.synthetic_measurement(truth, 4, dofs=dofs, freq_noise=0.002 * times, shape_noise=0.02 * times,
                                           seed=seed, model_name="four")


def _exact(cal, cm, refit_without):
    """Each mode's predicted frequency error (%) by an exact refit without it (`refit_without(obs, m)`
    -> (frequencies, shapes, scale) of the refitted class)."""
    out = []
    for m in range(cal.obs.n_modes):
        keep = np.delete(np.arange(cal.obs.n_modes), m)
        obs_m = Observations.of(cal.data, modes=cal.used[keep], freq_noise=cal.obs.freq_noise,
                                shape_noise=cal.obs.shape_noise)
        hz, sh, s = refit_without(obs_m)
        k = cm.pairing[m]
        out.append(100.0 * (hz[k] * np.sqrt(s) / cal.obs.frequencies_hz[m] - 1.0))
    return np.array(out)


def six_floors(times: float, seed: int, n_modes: int = 3):
    """A one-bay six-storey frame measured in x at its six floors, `n_modes` modes (the shape of the
    issue's 18-storey laboratory data); the truth its first storey's members (columns 1, 2 and beam
    3) 20 % softer, set directly in the elements (test_diagnosis_robust.six_floors); real noise
    `times` the stated 0.2 % / 2 %."""
    model = regular_frame(1, 6, 6.0, 3.0, floor_mass_kg=5000.0, name="six")
    dofs = tuple((s * 2 + 1, "x") for s in range(1, 7))
    truth = model.with_element_moduli({e: 0.8 * model.element_modulus_pa(e) for e in (1, 2, 3)})
    return model, fp.synthetic_measurement(truth, n_modes, dofs=dofs, freq_noise=0.002 * times,
                                           shape_noise=0.02 * times, seed=seed, model_name="six")


def test_the_first_order_refit_agrees_with_exact_refits():
    """Each mode's frequency predicted by the first-order refit without it agrees with an exact refit
    without it: the stiffness trend with height on the four-storey frame at 3 times the stated noise
    (the one-parameter fit, `fit.fit`) within 0.1 percentage points, and the two adjacent members
    free on the six-floor frame at 3 times (the class's bounded least squares, `sparse_class.refit`)
    within 0.02, against prediction errors of 0.2-1 % and 0.03-0.33 %. (Where a class has about as
    many parameters as a mode's data, the first order is rougher: the every-storey class's five on
    the six floors' three modes, 0.11/1.14/-3.19 % first order against 0.20/1.10/-2.86 % exact; both
    say that it predicts worst.)"""
    model, data = four_storeys(3, 1)
    cal = core.calibrate(model, data, 0.002, 0.02)
    trend = next(c for c in distributed_candidates(cal.setting) if c.label == "stiffness_trend@trend=linear_height+")
    f = fit(cal.obs, trend)
    cm = predictive.of_candidate(trend, f)
    first = np.array(predictive.leave_one_mode_out(cal.obs, cm, 1.0).frequency_error_pct)

    def refit_trend(obs_m):
        g = fit(obs_m, trend, f.a)
        hz, sh = trend.forward(np.array([g.a]))
        return hz[0], sh[0], g.s

    exact = _exact(cal, cm, refit_trend)
    assert np.max(np.abs(exact)) > 0.2
    np.testing.assert_allclose(first, exact, atol=0.1)

    model, data = six_floors(3, 1)
    cal = core.calibrate(model, data, 0.002, 0.02)
    pair = group_free.fit_pair(cal.setting, cal.obs, cal.base.pairing, {2})
    assert pair.members == (2, 5)
    cm = predictive.of_moduli(pair.label, pair.params, pair.fit, cal.obs)
    first = np.array(predictive.leave_one_mode_out(cal.obs, cm, 1.0).frequency_error_pct)
    support = np.array([pair.params.names.index(e) for e in pair.fit.members])

    def refit_pair(obs_m):
        base = pair.params.residuals(obs_m, np.zeros((1, len(pair.params.names))))[0]
        g = sparse_class.refit(pair.params, obs_m, support, pair.fit.theta, base.pairing)
        theta = np.zeros(len(pair.params.names))
        theta[support] = g.theta
        hz, sh = pair.params.modes(theta[None])
        return hz[0], sh[0], g.s

    exact = _exact(cal, cm, refit_pair)
    assert np.max(np.abs(exact)) > 0.2
    np.testing.assert_allclose(first, exact, atol=0.02)


# == the rule ====================================================================================
def _row(label, family, log_evidence):
    from fe_problem.diagnosis.evidence import ScoredClass

    return ScoredClass(label, family, 1, 0.0, log_evidence)


def _prediction(label, elpd):
    return predictive.Prediction(label, elpd, 0.0, (elpd,), (0.0,), 0.0)


def _follow(dispersion, rows, elpd, answer_label, decisive, may=lambda c: c.family != "local"):
    from fe_problem.diagnosis import answer
    from fe_problem.diagnosis.evidence import ranked

    ev = ranked(rows, "laplace", dispersion)
    row = next(c for c in ev.classes if c.label == answer_label)
    runner = next(c for c in ev.classes if c.label != answer_label)
    return predictive.follow(ev, {r.label: _prediction(r.label, e) for r, e in zip(rows, elpd)}, row, runner,
                             decisive, may, answer.same_answer)


def test_the_rule_follows_prediction_only_when_nothing_fits():
    """`predictive.follow` on evidence tables written out: a distributed class within ln 10 of a local
    answer that predicts better by more than `MARGIN` becomes the answer, not decisive, the local one
    its runner-up; a different answer that predicts better but lies decisively below in evidence
    makes a decisive answer not decisive; a local class may not replace the search's answer; and at
    a dispersion of 1 (some class fits within the noise) nothing changes."""
    rows = [_row("stiffness_loss@element=2", "local", 10.0), _row("every_storey_free@groups=a+b+c", "distributed", 9.0),
            _row("stiffness_loss@element=7", "local", 2.0)]
    row, runner, decisive, note = _follow(2.0, rows, [-50.0, -40.0, -49.0], "stiffness_loss@element=2", False)
    assert row.label == "every_storey_free@groups=a+b+c" and runner.label == "stiffness_loss@element=2"
    assert decisive is False and "it is the answer" in note
    # the same within MARGIN: nothing changes
    assert _follow(2.0, rows, [-50.0, -48.0, -49.0], "stiffness_loss@element=2", False)[3] is None
    # decisively apart in evidence (10 against 2), but predicting better: not decisive, named
    rows[1] = _row("every_storey_free@groups=a+b+c", "distributed", 2.0)
    rows[2] = _row("stiffness_loss@element=7", "local", 1.0)
    row, runner, decisive, note = _follow(2.0, rows, [-50.0, -40.0, -49.0], "stiffness_loss@element=2", True)
    assert row.label == "stiffness_loss@element=2" and decisive is False
    assert runner.label == "every_storey_free@groups=a+b+c" and "not decisive" in note
    # a local class close in evidence that predicts better does not replace the search's answer
    rows = [_row("stiffness_loss@element=2", "local", 10.0), _row("stiffness_loss@element=7", "local", 9.0)]
    row, _, decisive, note = _follow(2.0, rows, [-50.0, -40.0], "stiffness_loss@element=2", False)
    assert row.label == "stiffness_loss@element=2" and "not decisive" not in (note or "")
    # something fits within the noise: the evidence alone
    assert _follow(1.0, rows, [-50.0, -40.0], "stiffness_loss@element=2", True)[2:] == (True, None)


# == independent truths with 3-10 times the stated noise =========================================
def crack_at_3(times: float, seed: int):
    """The H-frame with a crack (a rotational spring inside element 3, the cracked-beam element, at
    0.4 of its length) sized to a 5 % largest frequency shift; 8 modes at the H-frame's channels."""
    import diagnosis_cases as dc

    truth = dc._sized(lambda k: dc.crack_truth(3, 0.4, k), 5.0, dc.CRACK_MIN_STIFFNESS, 1e8)
    return None, fp.synthetic_measurement(truth, dc.N_MODES, dofs=dc.HFRAME.measured_dofs, freq_noise=0.002 * times,
                                          shape_noise=0.02 * times, seed=seed, model_name="hframe")


def _storey_one(answer: dict) -> bool:
    """A right answer (the record's) for a first-storey loss: a class that softens only first-storey
    members (1, 2, 3), the first storey's group, a stiffness trend rising with height, or every
    storey free."""
    from fe_problem.diagnosis import answer as ans
    from fe_problem.diagnosis.evidence import ScoredClass

    label = answer["label"]
    if label.startswith(("group_stiffness_loss@group=storey1", "stiffness_trend@trend=linear_height+",
                         "every_storey_free@")):
        return True
    changed = ans.members_changed(ScoredClass(label, answer["family"], 0, 0.0, 0.0, answer["estimate"]))
    return changed is not None and all(e in (1, 2, 3) and sign < 0 for e, sign in changed)


def _storey_pattern(answer: dict) -> bool:
    return answer["label"].startswith(("stiffness_trend@trend=linear_height+", "every_storey_free@",
                                       "group_stiffness_loss@group=storey1"))


CASES = {  # name: (data, is the answer right, through the CLI)
    "six floors, storey 1, 3x": (lambda: six_floors(3, 1), _storey_one, False),
    "six floors, storey 1, 5x": (lambda: six_floors(5, 1), _storey_one, True),
    "four storeys, storey pattern, 3x": (lambda: four_storeys(3, 1), _storey_pattern, False),
    "four storeys, storey pattern, 10x": (lambda: four_storeys(10, 1), _storey_pattern, False),
    "H-frame crack in element 3, 3x": (lambda: crack_at_3(3, 0), lambda a: (a["location"] or {}).get("element") == 3,
                                       False),
}


def _through_cli(model, data, directory) -> dict:
    """`python -m femu diagnose DATA --model MODEL --json` as a user runs it: its record."""
    import dataclasses
    import json
    import subprocess
    import sys
    from pathlib import Path

    model_file = fp.save_model(model, directory / f"{model.name}.model.json")
    path = fp.save_modal_data(dataclasses.replace(data, model=model_file.name), directory / "data.json")
    done = subprocess.run([sys.executable, "-m", "femu", "diagnose", str(path), "--model", str(model_file), "--json"],
                          capture_output=True, text=True, cwd=Path(__file__).resolve().parents[1], timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout)


@pytest.fixture(scope="module")
def diagnosed(tmp_path_factory):
    """Each case's record (`Diagnosis.to_dict`; one case through the CLI's --json)."""
    return {name: _through_cli(*make(), tmp_path_factory.mktemp("cli")) if cli else fp.diagnose(*make()).to_dict()
            for name, (make, _, cli) in CASES.items()}


@pytest.mark.parametrize("name", list(CASES))
def test_with_3_to_10_times_the_noise_the_answer_predicts_and_is_never_decisively_wrong(diagnosed, name):
    """Independent truths (moduli or a crack set directly in the truth model, no candidate built so),
    real noise 3-10 times the stated: nothing fits within the stated noise (D > 1), every class
    scored has its leave-one-mode-out prediction in the record (the JSON `femu diagnose --json`
    prints, for one case), the answer's is within `MARGIN` of the best of them, and the answer is
    right or not decisive. The crack (a local truth) stays right. (Measured: six floors 3x: two
    adjacent members 2+5, not decisive, the trend its runner-up in evidence, 2+5 the best
    predictor; 5x: member 2's loss, not decisive; four storeys 3x: the stiffness trend, decisive and
    the best predictor; 10x: a stiffer top beam, not decisive; the crack: element 3's weak zone, not
    decisive against two adjacent members 3+4.)"""
    record = diagnosed[name]
    right = CASES[name][1]
    ev, answer = record["evidence"], record["answer"]
    assert ev["dispersion"] > 1.0 and record["adequate"] is False
    pred = {p["label"]: p["elpd_loo"] for p in ev["predictive"]}
    assert len(pred) >= 5
    # the answer's row (a local answer's label names its refined weak zone; its row the grid's)
    own = pred[next(c["label"] for c in ev["classes"] if c["label"].split("(")[0] == answer["label"].split("(")[0])]
    assert own >= max(pred.values()) - predictive.MARGIN
    assert right(answer) or not answer["decisive"]
    if name.startswith("H-frame"):
        assert right(answer)
