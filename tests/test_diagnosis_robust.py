"""No numerical exception escapes a diagnosis (issue 38): a candidate whose solve fails is dropped
with a warning naming it, degenerate model shapes reach the close-mode comparison without a LAPACK
error, and under `femu diagnose --json` stdout holds only the JSON even when a library writes to
the C-level stdout."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse.linalg import ArpackNoConvergence

import fe_problem as fp
from fe_problem.correlation import MAX_PAIR_FREQ
from fe_problem.diagnosis import kinds as registry, supports
from fe_problem.diagnosis.residuals import Observations
from fe_problem.model.generate import regular_frame

import diagnosis_cases as dc

ROOT = Path(__file__).resolve().parents[1]


def six_floors():
    """A one-bay six-storey frame measured in x at its six floors, three modes (the shape of the
    issue's 18-storey laboratory data: few modes at few floors), its first storey's members 20 %
    softer, set directly in the elements (no candidate builds it so)."""
    model = regular_frame(1, 6, 6.0, 3.0, floor_mass_kg=5000.0, name="six")
    dofs = tuple((s * 2 + 1, "x") for s in range(1, 7))
    truth = model.with_element_moduli({e: 0.8 * model.element_modulus_pa(e) for e in model.element_ids[:3]})
    return model, fp.synthetic_measurement(truth, 3, dofs=dofs, freq_noise=0.002, shape_noise=0.02, seed=0,
                                           model_name="six")


@pytest.fixture(scope="module")
def crack_case():
    """An H-frame crack (a rotational spring inside element 3, the cracked-beam element)."""
    case = dc.make_case("stiffness_loss", np.random.default_rng(3), 3)
    assert case.location == {"element": 3}
    return case


def test_a_mode_that_does_not_move_the_measured_coordinates_is_a_lost_mode():
    """A model mode with a close neighbour whose shape is zero (or NaN) at the measured coordinates
    went to `close_mode_shape` and made LAPACK fail ("SVD did not converge in Linear Least
    Squares"); it is now a lost mode: the residuals of a mode paired with nothing, written out here
    by hand (frequency 30 % off, shape orthogonal)."""
    rng = np.random.default_rng(0)
    u = rng.standard_normal((5, 3))
    u /= np.linalg.norm(u, axis=0)
    data = fp.ModalData("m", tuple((n, "x") for n in range(1, 6)), np.array([10.0, 20.0, 30.0]), u)
    obs = Observations.of(data, freq_noise=0.002, shape_noise=0.02)
    model_hz = np.array([10.0, 10.01, 30.0])   # modes 0 and 1 within the close-mode reach
    for bad in (0.0, np.nan):
        shapes = u.copy()
        shapes[:, 0] = bad
        r, _ = obs.residuals(model_hz, shapes, np.array([0, 1, 2]))
        assert np.isfinite(r).all()
        # the lost mode 0: frequency as if MAX_PAIR_FREQ off, shape as if orthogonal (model entry 0)
        assert r[0] == pytest.approx(MAX_PAIR_FREQ / 0.002)
        u_m = obs.shapes[:, 0]
        assert np.allclose(r[3:8], -u_m / (0.02 * np.max(np.abs(u_m))))
        # mode 1 is compared with itself alone (its neighbour gives nothing): its shape residual is 0
        assert np.allclose(r[8:13], 0.0, atol=1e-9)


def test_degenerate_support_shapes_on_the_issue_path_complete(monkeypatch):
    """The issue's path: a support condition's look along its grid (modelform.screen_forms ->
    fit.look_along -> residuals.close_mode_shape). Its far sizes are given a mode that does not move
    the floors, beside a close neighbour (at 7e9dde1 this data stopped with LinAlgError "SVD did
    not converge in Linear Least Squares" and LAPACK's DLASCL messages): the diagnosis completes
    and its answer changes a member of the softer first storey."""
    made = supports._candidate

    def degenerate(*args, **kw):
        c = made(*args, **kw)
        solve = c.forward.solve

        def forward(a, solve=solve, upper=c.upper):
            hz, sh = (x.copy() for x in solve(a))
            far = np.asarray(a) >= 0.5 * upper
            hz[far, 1] = hz[far, 0] * 1.001
            sh[far, :, 0] = 0.0
            return hz, sh
        return dataclasses.replace(c, forward=forward)

    monkeypatch.setattr(supports, "_candidate", degenerate)
    model, data = six_floors()
    d = fp.diagnose(model, data)
    assert d.answer is not None and d.answer.family != "none"
    changed = d.cause.location.get("members") or [d.cause.location.get("element")]
    assert set(changed) & {1, 2, 3}  # the first storey's columns (1, 2) and beam (3)


def test_a_failing_candidate_is_dropped_named_and_the_answer_stays(monkeypatch, crack_case):
    """Two candidates' solves raise (LAPACK's and ARPACK's errors); the run completes, names both
    in `dropped` and in a warning, scores neither, and still names the cracked element."""
    failing = {"stiffness_loss@element=5": np.linalg.LinAlgError("SVD did not converge"),
               "added_mass@node=4": ArpackNoConvergence("ARPACK error -1: No convergence", None, None)}
    def wrapped(gen):
        def make(st):
            for c in gen(st):
                if c.label in failing:
                    def broken(a, exc=failing[c.label]):
                        raise exc
                    c = dataclasses.replace(c, forward=broken)
                yield c
        return make

    for kind in ("stiffness_loss", "added_mass"):
        spec = registry.KINDS[kind]
        monkeypatch.setitem(registry.KINDS, kind, dataclasses.replace(spec, generate=wrapped(spec.generate)))
    d = fp.diagnose(None, crack_case.data())
    named = {x["label"]: x["reason"] for x in d.dropped}
    assert set(failing) <= set(named)
    assert "SVD did not converge" in named["stiffness_loss@element=5"]
    assert "ARPACK" in named["added_mass@node=4"]
    for label in failing:
        assert any(label in w and "dropped" in w for w in d.warnings)
        assert all(c.label != label for c in d.evidence.classes)
        assert all(not (c.label == label and c.fitted) for c in d.candidates)
    assert d.cause.location == {"element": 3}
    assert json.loads(json.dumps(d.to_dict()))["dropped"][0]["label"] in failing


def test_json_stdout_is_only_json_when_a_library_writes_to_fd_1(tmp_path, crack_case):
    """`femu diagnose --json` in a subprocess whose diagnosis writes LAPACK-like lines to the
    C-level stdout (file descriptor 1, as LAPACK's xerbla does): stdout parses as JSON, the lines
    are on stderr."""
    path = fp.save_modal_data(crack_case.data(), tmp_path / "crack.json")
    script = textwrap.dedent(f"""
        import os, sys
        import fe_problem
        real = fe_problem.diagnose

        def noisy(*args, **kw):
            os.write(1, b" ** On entry to DLASCL parameter number  4 had an illegal value\\n")
            print("a Python print inside the computation")
            return real(*args, **kw)

        fe_problem.diagnose = noisy
        from femu.cli import main
        sys.exit(main(["diagnose", {str(path)!r}, "--json"]))
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    record = json.loads(done.stdout)
    assert record["cause"]["location"] == {"element": 3}
    assert "DLASCL" in done.stderr and "a Python print" in done.stderr


# == the class chosen when no class fits within the noise ======================================
def four_storeys():
    """A one-bay four-storey frame; the truth: its storeys' moduli 0.7, 0.8, 0.9 and 1 of nominal,
    set directly in the elements (no candidate class is built so: the trend is linear in height,
    the groups change one storey, the sparse class picks members)."""
    model = regular_frame(1, 4, 6.0, 3.0, floor_mass_kg=5000.0, name="four")
    ratio = {1: 0.7, 2: 0.8, 3: 0.9, 4: 1.0}
    top = {e.id: int(round(max(model.node(e.node_i).y, model.node(e.node_j).y) / 3.0)) for e in model.elements}
    truth = model.with_element_moduli({e: ratio[s] * model.element_modulus_pa(e) for e, s in top.items()
                                       if ratio[s] != 1.0})
    return model, truth


@pytest.mark.parametrize("times, seed", [(3, 1), (3, 2), (5, 0), (10, 1)])
def test_with_more_noise_than_stated_the_chosen_class_predicts_the_held_out_mode(times, seed):
    """Real noise 3-10 times the stated (0.2 % / 2 %), 4 modes at the 4 floors (x), the highest held
    out: no class fits within the stated noise, and the answer is the class that predicts the
    held-out mode best, within that mode's own frequency noise (`times` x 0.2 %), among every class
    whose held-out error the evidence table gives. (At 3 and 5 times the answer is the stiffness
    trend with height, the truth's shape; at 10 times, seed 1, a stiffer top beam, which predicts
    the held-out mode best there: 0.34 % against the trend's 3.1 %.)"""
    model, truth = four_storeys()
    dofs = tuple((s * 2 + 1, "x") for s in range(1, 5))
    data = fp.synthetic_measurement(truth, 4, dofs=dofs, freq_noise=0.002 * times, shape_noise=0.02 * times,
                                    seed=seed, model_name="four")
    d = fp.diagnose(model, data)
    assert d.adequate is False and d.evidence.dispersion > 1.0  # nothing fits within the stated noise
    rows = {c.label: c for c in d.evidence.classes if c.held_out_error_pct is not None}
    chosen = rows[d.answer.label]
    others = [c.held_out_error_pct for label, c in rows.items() if label != d.answer.label]
    assert len(others) >= 3
    assert chosen.held_out_error_pct <= min(others) + 100 * 0.002 * times
    # docs/diagnosis-real-data.md's figures of these four draws, to their printed precision
    import re

    page = " ".join((Path(__file__).resolve().parents[1] / "docs" / "diagnosis-real-data.md").read_text().split())
    assert "storeys' moduli are 0.7, 0.8 and 0.9 of nominal (the fourth nominal)" in page
    lo, hi = re.search(r"Nothing fits within the stated noise \(D ([\d.]+) to ([\d.]+)\)", page).groups()
    D = d.evidence.dispersion
    assert float(lo) - 0.05 <= D <= float(hi) + 0.05
    assert f"{D:.1f}" == {(3, 1): lo, (10, 1): hi}.get((times, seed), f"{D:.1f}")
    trend = "stiffness_trend@trend=linear_height+"
    if times < 10:  # "At 3 and 5 times the answer is the stiffness trend with height (held-out error a-b %)"
        lo, hi = re.search(r"At 3 and 5 times the answer is the stiffness trend with height \(held-out error "
                           r"([\d.]+)-([\d.]+) %\)", page).groups()
        err = chosen.held_out_error_pct
        assert d.answer.label == trend and float(lo) - 0.005 <= err <= float(hi) + 0.005
        assert f"{err:.2f}" == {(5, 0): lo, (3, 2): hi}.get((times, seed), f"{err:.2f}")
    else:  # "at 10 times (seed 1) a stiffer top beam, which predicts best there (a % against the trend's b %)"
        said = re.search(r"at 10 times \(seed 1\) a stiffer top beam, which predicts best there \(([\d.]+) % "
                         r"against the trend's ([\d.]+) %\)", page)
        assert d.answer.kind == "stiffness_gain" and said.groups() == (
            f"{chosen.held_out_error_pct:.2f}", f"{rows[trend].held_out_error_pct:.1f}")


def test_python_m_femu_diagnose_json_on_few_modes_at_few_floors(tmp_path):
    """`python -m femu diagnose --json` as a user runs it on the three-mode six-floor data with the
    model file beside it: exit 0, stdout is one JSON document, the answer is named."""
    model, data = six_floors()
    model_file = fp.save_model(model, tmp_path / "six.model.json")
    path = fp.save_modal_data(dataclasses.replace(data, model="six.model.json"), tmp_path / "six.modal.json")
    done = subprocess.run([sys.executable, "-m", "femu", "diagnose", str(path), "--model", str(model_file), "--json"],
                          capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    record = json.loads(done.stdout)
    assert record["answer"]["family"] != "none" and record["dropped"] == []
