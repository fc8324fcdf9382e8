"""`femu diagnose` on a model given as matrices (fe_problem/diagnosis/matrix.py, the kinds of
kinds/matrix_terms.py, matrix_mass.py, matrix_spring.py).

The model: a five-storey column frame assembled in tests/matrix_cases.py from the textbook frame
element (one stiffness matrix per storey, masses on the floors' translations, every rotation
without mass). The "measured" modes: the truth's own matrices with the effect made physically
(a storey column's bending stiffness lowered inside that storey's assembly, EA unchanged; a mass
on a stiff spring as an extra DOF; a spring element to a ground node), its massless DOFs
condensed out and solved by scipy.linalg.eigh, with noise at the stated level (0.2 %, 2 %).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

import fe_problem as fp
from fe_problem.diagnosis import diagnose
from fe_problem.modal_data import ModalData, save_modal_data

sys.path.insert(0, str(Path(__file__).resolve().parent))
from matrix_cases import Frame, condensed_modes, measured, truth  # noqa: E402

ENV = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1]), "OPENBLAS_NUM_THREADS": "1",
       "FEMU_SOLVER_WORKERS": "1"}
N_MODES = 5


@pytest.fixture(scope="module")
def column(tmp_path_factory):
    """(frame, manifest path, model, measured DOFs): the five-storey column, x measured at every floor."""
    folder = tmp_path_factory.mktemp("column")
    fr = Frame(storeys=5, bays=0)
    path = fr.write(folder)
    return fr, path, fp.load_any_model(path), [(n, "x") for n in fr.free]


def test_the_model_solved_by_femu_gives_the_condensed_eigh_frequencies(column):
    """The matrix model (massless rotations, femu's sparse solver) against the truth's route
    (static condensation, scipy.linalg.eigh) on the same matrices: the truth and the model agree
    before any effect, so what a diagnosis finds is the effect."""
    fr, path, model, _ = column
    k, m = truth(fr)
    hz, _ = condensed_modes(k, m, 8)
    assert int(np.sum(model.total("mass").diagonal() == 0)) == 5  # the rotations carry no mass
    np.testing.assert_allclose(fp.modal_analysis(model, 8).frequencies_hz, hz, rtol=1e-9)


CASES = {
    # storey 2's column at 0.7 of its bending stiffness (EA unchanged): the storey's term softer
    "storey_loss": (dict(soft=(2, 0, 0.7)), "term_loss", {"term": "storey2"}, ("ratio", 0.7, 0.04)),
    # 1.5 t on a stiff spring at floor 3 (node 4): a mass at that DOF
    "added_mass": (dict(mass_at=((4, "x"), 1500.0)), "dof_mass", {"node": 4, "direction": "x"},
                   ("mass_kg", 1500.0, 0.1 * 1500.0)),
    # a spring element of 2 MN/m from floor 2 (node 3) to the ground
    "spring": (dict(spring_at=((3, "x"), 2.0e6)), "dof_spring", {"node": 3, "direction": "x"},
               ("stiffness", 2.0e6, 0.1 * 2.0e6)),
}


@pytest.mark.parametrize("case", list(CASES))
def test_the_right_kind_and_place_found(column, case):
    fr, path, model, dofs = column
    effect, kind, place, (key, value, tol) = CASES[case]
    k, m = truth(fr, **effect)
    diag = diagnose(model, measured(fr, path, k, m, dofs, n_modes=N_MODES, seed=1))
    a = diag.answer
    assert (a.kind, a.location, a.family) == (kind, place, "local")
    assert a.decisive and diag.adequate
    assert diag.cause.kind == kind and diag.cause.identifiable
    assert abs(diag.cause.estimate[key] - value) < tol, diag.cause.estimate
    assert diag.gain.after is not None  # the held-out mode predicted by the extended model
    assert diag.gain.after.mean_abs_error_pct < diag.gain.before.mean_abs_error_pct


def test_two_storeys_softer_are_the_sparse_class_over_terms(column):
    """Storeys 2 and 4 softer (their columns at 0.7 and 0.8 of their bending stiffness): no one
    term explains it; "every term, sparse" names both, each near its truth."""
    fr, path, model, dofs = column
    k = sum(fr.storey_matrix(s, {0: {2: 0.7, 4: 0.8}[s]} if s in (2, 4) else None) for s in range(1, 6))
    diag = diagnose(model, measured(fr, path, k, fr.mass_matrix(), dofs, n_modes=N_MODES, seed=2))
    a = diag.answer
    assert a.family == "sparse" and a.kind == "every_term_sparse" and a.decisive
    assert a.location == {"terms": ["storey2", "storey4"]}
    np.testing.assert_allclose(a.estimate["ratio"], [0.7, 0.8], atol=0.04)
    assert diag.adequate
    ext = diag.extended_model
    s = a.estimate["global_scale"]
    assert ext.term("storey2").initial == pytest.approx(s * a.estimate["ratio"][0])
    assert ext.term("storey1").initial == pytest.approx(s)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_null_data_quiet(column, seed):
    """The model's own structure, noise only: no cause, and no decisive answer naming one."""
    fr, path, model, dofs = column
    k, m = truth(fr)
    diag = diagnose(model, measured(fr, path, k, m, dofs, n_modes=N_MODES, seed=seed))
    assert diag.cause.is_none
    assert diag.answer.family == "none" or not diag.answer.decisive
    assert diag.extended_model is None


def test_a_reversed_channel_is_left_out_and_the_answer_not_decisive(column):
    """The mass case's data with the channel at the mass (floor 3, node 4) reversed in polarity:
    the data checks name it, the diagnosis leaves it out, and no answer on faulty data is decisive."""
    fr, path, model, dofs = column
    k, m = truth(fr, mass_at=((4, "x"), 1500.0))
    d = measured(fr, path, k, m, dofs, n_modes=N_MODES, seed=1)
    shapes = d.shapes.copy()
    shapes[dofs.index((4, "x"))] *= -1.0
    diag = diagnose(model, ModalData(d.model, d.dofs, d.frequencies_hz, shapes, d.meta))
    assert [c.kind for c in diag.data_checks] == ["channel_polarity"]
    assert diag.left_out == {"channels": [[4, "x"]]}
    assert not diag.answer.decisive and "fault" in diag.answer.not_decisive_because


def test_row_numbered_dofs_and_a_mass_at_a_row(tmp_path, column):
    """A manifest that counts its DOFs (row numbers), data at row numbers: the same mass found,
    named by its row."""
    fr, _, _, dofs = column
    folder = tmp_path / "counted"
    folder.mkdir()
    doc = json.loads(fr.write(folder).read_text())
    doc["dofs"] = fr.n
    (folder / "frame.json").write_text(json.dumps(doc))
    model = fp.load_any_model(folder / "frame.json")
    k, m = truth(fr, mass_at=((4, "x"), 1500.0))
    data = measured(fr, folder / "frame.json", k, m, dofs, n_modes=N_MODES, seed=3)
    rows = tuple(fr.row[d] + 1 for d in dofs)
    data = ModalData(data.model, rows, data.frequencies_hz, data.shapes, data.meta)
    diag = diagnose(model, data)
    assert (diag.answer.kind, diag.answer.location) == ("dof_mass", {"dof": fr.row[(4, "x")] + 1})
    assert diag.answer.decisive


def _run(*args):
    return subprocess.run([sys.executable, "-m", "femu", "diagnose", *map(str, args)], capture_output=True,
                          text=True, env=ENV, timeout=300)


def test_cli_diagnose_on_a_matrix_manifest(column, tmp_path):
    """`python -m femu diagnose DATA --model MANIFEST --out DIR --json`: stdout is the JSON alone,
    the extended model is a matrix manifest with its files (the new mass term's among them) that
    loads and gives the modes the diagnosis fitted, and report.md is written."""
    fr, path, _, dofs = column
    k, m = truth(fr, mass_at=((4, "x"), 1500.0))
    data = save_modal_data(measured(fr, path, k, m, dofs, n_modes=N_MODES, seed=1), tmp_path / "mass.json")
    out = tmp_path / "out"
    r = _run(data, "--model", path, "--out", out, "--json")
    assert r.returncode == 0, r.stderr
    record = json.loads(r.stdout)
    assert record["answer"]["kind"] == "dof_mass" and record["answer"]["decisive"]
    assert record["extended_model"]["format"] == "femu.matrix-model/1"
    assert (out / "report.md").is_file() and (out / "diagnosis.json").is_file()
    ext = fp.load_any_model(out / "extended.model.json")
    added = [t for t in ext.mass if t.name.startswith("diagnosis-mass")]
    assert len(added) == 1 and added[0].matrix[fr.row[(4, "x")], fr.row[(4, "x")]] == pytest.approx(
        record["cause"]["estimate"]["mass_kg"])
    # the extended model's frequencies are those the diagnosis's final fit paired with the data
    after = fp.modal_analysis(ext, N_MODES).frequencies_hz
    measured_hz = np.array(record["residuals"]["measured_hz"])
    assert np.max(np.abs(after / measured_hz - 1)) < 0.01
    assert np.max(np.abs(np.array(record["residuals"]["model_hz"]) / measured_hz - 1)) > 0.01


def test_bad_inputs_one_line(column, tmp_path, capsys):
    """Through the CLI (in process): a DOF the model lacks, a noise given as a percentage, a term name
    the diagnosis keeps for its own terms: exit 2, one line on stderr; an unknown kind in the library."""
    from femu.cli import main

    fr, path, _, dofs = column
    k, m = truth(fr)
    good = measured(fr, path, k, m, dofs, n_modes=N_MODES, seed=1)
    bad = save_modal_data(ModalData(good.model, ((99, "x"),) + good.dofs[1:], good.frequencies_hz, good.shapes),
                          tmp_path / "bad.json")
    data = save_modal_data(good, tmp_path / "good.json")
    doc = json.loads(path.read_text())
    doc["stiffness"][0]["name"] = "+mass@3"
    (path.parent / "clash.json").write_text(json.dumps(doc))
    for args, needle in (([bad, "--model", path], "no DOF [99, 'x']"),
                         ([data, "--model", path, "--freq-noise", "2"], "a fraction, not a percentage"),
                         ([data, "--model", path.parent / "clash.json"], "'+mass@3'")):
        assert main(["diagnose", *map(str, args)]) == 2
        out, err = capsys.readouterr()
        lines = err.strip().splitlines()
        assert out == "" and len(lines) == 1 and needle in lines[0], err
    with pytest.raises(ValueError, match="not a model given as matrices'"):
        diagnose(path, good, kinds=["stiffness_loss"])


def test_nested_evidence_agrees_with_laplace(column, monkeypatch):
    """`evidence="nested"` on the storey-loss case: the best class (only it, to keep the test short:
    `nested.rescored` with n_nested=1) sampled by dynesty has the log evidence its Laplace value
    gives, within 1 (two independent integrations of one likelihood)."""
    from fe_problem.diagnosis import matrix, nested

    fr, path, model, dofs = column
    k, m = truth(fr, soft=(2, 0, 0.7))
    data = measured(fr, path, k, m, dofs, n_modes=N_MODES, seed=1)
    laplace = diagnose(model, data).evidence.classes[0]
    monkeypatch.setattr(matrix, "rescored", lambda *a: nested.rescored(*a, n_nested=1))
    best = diagnose(model, data, evidence="nested").evidence.classes[0]
    assert best.label == laplace.label == "term_loss@term=storey2"
    assert best.method == "nested" and laplace.method == "laplace"
    assert abs(best.log_evidence - laplace.log_evidence) < 1.0, (best.log_evidence, laplace.log_evidence)


def test_first_order_terms_against_finite_differences_of_solves(column):
    """Each matrix kind's first-order term (kinds/: +-K_i, e_d e_d^T, k_ref e_d e_d^T) through the
    frames' first-order screen (screening.py: phi^T (dK - lambda dM) phi, Nelson's shape change by
    the bordered adjoint on the singular M) against central differences of the candidate's own exact
    solves; and the screen's promised drops against `fit.screen`'s exact step (the same ranking)."""
    from fe_problem.diagnosis.fit import screen
    from fe_problem.diagnosis.matrix import calibrate_matrix, matrix_candidates
    from fe_problem.diagnosis.screening import baseline, changes, screen_all

    fr, path, model, dofs = column
    k, m = truth(fr, mass_at=((4, "x"), 1500.0))
    cal = calibrate_matrix(model, measured(fr, path, k, m, dofs, n_modes=N_MODES, seed=1), 0.002, 0.02)
    st = cal.setting
    cands = matrix_candidates(st)
    base = baseline(st.screen_setting.system, st.coords, st.n_modes)
    picked = [next(c for c in cands if c.kind == kind) for kind in ("term_loss", "term_gain", "dof_mass", "dof_spring")]
    dlam, dshape = changes(base, [c.term() for c in picked])
    for c, dl, ds in zip(picked, dlam, dshape):
        h = 0.1 * c.step
        hz, sh = c.forward(np.array([h, 2 * h]))  # one-sided: a >= 0; second order from the two steps
        lam = (2 * np.pi * hz) ** 2
        fd_lam = (4 * lam[0] - lam[1] - 3 * base.lam) / (2 * h)
        fd_shape = (4 * sh[0] - sh[1] - 3 * base.phi_c) / (2 * h)
        used = slice(0, N_MODES)  # the modes the data pair with (above them differences lose to rounding)
        np.testing.assert_allclose(dl[used], fd_lam[used], rtol=1e-4, atol=1e-6 * np.abs(fd_lam[used]).max(),
                                   err_msg=c.label)
        np.testing.assert_allclose(ds[:, used], fd_shape[:, used], atol=1e-4 * np.abs(fd_shape[:, used]).max(),
                                   err_msg=c.label)
    first = screen_all(cal.obs, cal.base, model, st.coords, st.n_modes, cands, st.screen_setting)
    exact = [screen(cal.obs, c, cal.base) for c in cands]
    np.testing.assert_allclose([f[0] for f in first], [e[0] for e in exact], rtol=0.05, atol=0.05)
    assert np.argsort([-f[0] for f in first])[:3].tolist() == np.argsort([-e[0] for e in exact])[:3].tolist()


def test_a_term_too_large_for_a_first_order_block_is_screened_by_exact_steps(column, monkeypatch):
    """A term touching more DOFs than `MAX_TERM_DOFS` has no first-order term (its dense block would
    be too large): it is screened by exact steps, and the storey loss is found as before."""
    from fe_problem.diagnosis.kinds import matrix_terms

    fr, path, model, dofs = column
    monkeypatch.setattr(matrix_terms, "MAX_TERM_DOFS", 2)
    k, m = truth(fr, soft=(2, 0, 0.7))
    diag = diagnose(model, measured(fr, path, k, m, dofs, n_modes=N_MODES, seed=1))
    assert (diag.answer.kind, diag.answer.location, diag.answer.decisive) == ("term_loss", {"term": "storey2"}, True)
    assert not diag.dropped


def test_an_answer_that_misfits_is_not_decisive(tmp_path):
    """A one-bay frame whose storey-2 left column alone is at 0.6 of its bending stiffness: a part of
    that storey's matrix, which no class of a matrix model expresses. Whatever class is named, the
    verdict says it does not fit within the noise and the answer is not decisive (`_misfit_note`)."""
    fr = Frame(storeys=4, bays=1)
    path = fr.write(tmp_path)
    dofs = [(n, "x") for n in fr.free if n % 2 == 1] + [(10, "y")]
    k, m = truth(fr, soft=(2, 0, 0.6))
    diag = diagnose(path, measured(fr, path, k, m, dofs, n_modes=6, seed=1))
    assert diag.adequate is False and diag.answer.family == "local" and not diag.answer.decisive
    assert "does not fit within the noise" in diag.answer.not_decisive_because
