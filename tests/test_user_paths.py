"""The user paths that join models given as matrices (issue 35), imported Nastran decks (issue 36)
and ambient identification (issue 37), each through the CLI:

(a) `femu update` on a matrix model: its manifest's parameters, updated-model.json a manifest at
    the estimates that loads from the output directory and gives `updated_hz`; the same 3-D
    frame as a frame model and as matrices assembled by an independent code
    (tests/test_matrix_model.py) updates to the same estimates to 1e-6 on noisy data;
(b) `femu study --model MANIFEST --data DATA` with its report (on the building of (d));
(c) `femu update` on a model imported from a Nastran deck writes updated-model.bdf, the changed
    MAT1/CONM2/CELAS2 values the estimates (read back with pyNastran), every other card as it was;
(d) `femu identify --oma --model MANIFEST` with channels labelled by DOF number (records simulated
    by tests/oma_sim.py, independent of the project's modal code), its deviations the noise of
    `femu update`; `femu diagnose` refuses a matrix model in one line;
(e) `femu identify` of FRFs with a matrix model whose DOF labels name the channels.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

import fe_problem as fp
from fe_problem.modal_data import ModalData, load_modal_data, save_modal_data
from femu.cli import main
from test_matrix_model import GROUPS, HIGH, LOW, TRUTH, independent_frame3d, write_manifest


def _one_line_error(capsys, args) -> str:
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


# --- (a) a matrix model through `femu update`, and the same frame as a frame model ---------------

@pytest.fixture(scope="module")
def frame3d_files(tmp_path_factory):
    """frame3d as matrices (manifest + .npz, one stiffness per group) and as the shipped frame with
    a parameter file of the same groups; noisy data of the frame at TRUTH for each; `femu update`
    run on both (the default optimizer, budget 40)."""
    d = tmp_path_factory.mktemp("frame3d")
    (d / "model").mkdir()
    ks, mass, members, labels, e0 = independent_frame3d()
    manifest = write_manifest(d / "model", [(g, ks[g], {"lower": LOW, "upper": HIGH}) for g in GROUPS],
                              [("mass", mass, {})], [list(lab) for lab in labels], name="frame3d-matrices")
    frame = fp.load_model("frame3d")
    params = tuple(fp.Parameter("modulus", tuple(members[g]), LOW * e0, HIGH * e0, e0, name=g) for g in GROUPS)
    data = fp.synthetic_measurement(frame, 8, parameters=params, theta=TRUTH * e0, seed=3)
    rng = np.random.default_rng(5)  # noise: the estimates are not the truth, so agreeing says something
    data = dataclasses.replace(data, frequencies_hz=data.frequencies_hz * (1 + 0.003 * rng.standard_normal(8)),
                               shapes=data.shapes + 0.01 * np.abs(data.shapes).max(axis=0)
                               * rng.standard_normal(data.shapes.shape))
    save_modal_data(dataclasses.replace(data, model="frame3d"), d / "frame-data.json")
    save_modal_data(dataclasses.replace(data, model=str(manifest)), d / "matrix-data.json")
    (d / "params.json").write_text(json.dumps({"format": "femu.parameters/1", "parameters": [
        {"name": g, "kind": "modulus", "targets": list(members[g]), "lower": LOW * e0, "upper": HIGH * e0}
        for g in GROUPS]}))
    common = ["--budget", "40", "--no-progress"]
    assert main(["update", "frame3d", str(d / "frame-data.json"), "--parameters", str(d / "params.json"),
                 "--out", str(d / "frame-out"), *common]) == 0
    assert main(["update", str(manifest), str(d / "matrix-data.json"), "--out", str(d / "matrix-out"), *common]) == 0
    return d, manifest, e0


def test_frame_and_matrix_model_update_to_the_same_estimates(frame3d_files):
    d, _, e0 = frame3d_files
    frame = json.loads((d / "frame-out" / "update.json").read_text())
    matrix = json.loads((d / "matrix-out" / "update.json").read_text())
    assert [p["name"] for p in matrix["parameters"]] == list(GROUPS)
    assert all(p["kind"] == "stiffness multiplier" for p in matrix["parameters"])
    x_frame = np.array([p["estimate"] for p in frame["parameters"]]) / e0
    x_matrix = np.array([p["estimate"] for p in matrix["parameters"]])
    np.testing.assert_allclose(x_matrix, x_frame, rtol=1e-6)
    assert np.abs(x_matrix - TRUTH).max() > 1e-4  # the noise moved the estimate off the truth
    for a, b in zip(frame["parameters"], matrix["parameters"]):  # the same intervals, in multipliers
        np.testing.assert_allclose(np.array(b["interval_95"]), np.array(a["interval_95"]) / e0, rtol=1e-4)
        assert a["interval_95"][0] / e0 < TRUTH[list(GROUPS).index(a["name"])] < a["interval_95"][1] / e0
    np.testing.assert_allclose([m["updated_hz"] for m in matrix["modes"]], [m["updated_hz"] for m in frame["modes"]],
                               rtol=1e-8)
    assert matrix["parameters_note"].startswith("the manifest's parameters")
    assert "stiffness multiplier" in (d / "matrix-out" / "report.md").read_text()


def test_updated_manifest_loads_from_the_output_and_gives_updated_hz(frame3d_files, tmp_path):
    d, manifest, _ = frame3d_files
    out = d / "matrix-out"
    record = json.loads((out / "update.json").read_text())
    doc = json.loads((out / "updated-model.json").read_text())
    assert doc["format"] == "femu.matrix-model/1"
    assert [t["initial"] for t in doc["stiffness"]] == [p["estimate"] for p in record["parameters"]]
    assert [(t["lower"], t["upper"]) for t in doc["stiffness"]] == [(LOW, HIGH)] * len(GROUPS)
    # the matrices are copied beside it: the directory moved elsewhere still loads
    moved = tmp_path / "moved"
    moved.mkdir()
    for f in out.iterdir():
        (moved / f.name).write_bytes(f.read_bytes())
    assert all(not Path(t["file"]).is_absolute() and (moved / t["file"]).is_file() for t in doc["stiffness"] + doc["mass"])
    updated = fp.load_any_model(moved / "updated-model.json")
    f = fp.modal_analysis(updated, 10).frequencies_hz
    for m in record["modes"]:
        assert f[m["model_mode_updated"] - 1] == pytest.approx(m["updated_hz"], rel=1e-9)
    # and it is the original matrices with new multipliers
    assert (updated.term("beams_x").matrix != fp.load_any_model(manifest).term("beams_x").matrix).nnz == 0


def test_parameter_file_for_a_matrix_model_refused_in_one_line(frame3d_files, capsys, tmp_path):
    d, manifest, _ = frame3d_files
    line = _one_line_error(capsys, ["update", str(manifest), str(d / "matrix-data.json"), "--parameters",
                                    str(d / "params.json"), "--out", str(tmp_path / "o")])
    assert "a matrix model carries its parameters in its manifest" in line and "params.json" in line
    assert not (tmp_path / "o").exists()


def test_matrix_model_without_parameters_refused_in_one_line(tmp_path, capsys):
    path = write_manifest(tmp_path, [("k", np.array([[2.0, -1.0], [-1.0, 2.0]]), {})], [("m", np.eye(2), {})], 2)
    (tmp_path / "d.json").write_text(json.dumps({"format": "femu.modal-data/1", "model": "model.json", "dofs": [1, 2],
                                                 "modes": [{"frequency_hz": 0.16}]}))
    line = _one_line_error(capsys, ["update", str(path), str(tmp_path / "d.json"), "--out", str(tmp_path / "o")])
    assert "no term has lower and upper" in line and str(path) in line


# --- (c) an imported Nastran deck through `femu update` -------------------------------------------

def test_update_of_an_imported_deck_writes_the_deck_back(tmp_path):
    pytest.importorskip("pyNastran")
    from fe_problem.model.nastran import _new_bdf, read_bdf
    from test_import_nastran import _pynastran_deck

    _pynastran_deck(tmp_path / "frame.bdf")
    assert main(["import", str(tmp_path / "frame.bdf"), "--out", str(tmp_path / "frame.json")]) == 0
    model = fp.load_model(tmp_path / "frame.json")
    params = (fp.Parameter("modulus", (1, 2, 3, 4), 1.5e11, 2.5e11, 2.0e11, name="E"),
              fp.Parameter("mass", (3,), 1.0, 5.0, 2.5, name="m3"),
              fp.Parameter("spring", (200,), 1.0e5, 6.0e5, 3.0e5, name="k200"))
    dofs = [(n, c) for n in (2, 3, 4, 5) for c in "xyz"]
    data = fp.synthetic_measurement(model, 6, parameters=params, theta=np.array([2.2e11, 3.1, 2.4e5]), seed=1,
                                    dofs=dofs)
    rng = np.random.default_rng(2)
    data = dataclasses.replace(data, model=str(tmp_path / "frame.json"),
                               frequencies_hz=data.frequencies_hz * (1 + 0.002 * rng.standard_normal(6)))
    save_modal_data(data, tmp_path / "data.json")
    (tmp_path / "params.json").write_text(json.dumps({"format": "femu.parameters/1", "parameters": [
        {"name": p.name, "kind": p.kind, "targets": list(p.targets), "lower": p.lower, "upper": p.upper}
        for p in params]}))
    out = tmp_path / "out"
    assert main(["update", str(tmp_path / "frame.json"), str(tmp_path / "data.json"), "--parameters",
                 str(tmp_path / "params.json"), "--out", str(out), "--budget", "40", "--no-progress"]) == 0
    record = json.loads((out / "update.json").read_text())
    est = {p["name"]: p["estimate"] for p in record["parameters"]}
    assert est["E"] != 2.0e11 and est["m3"] != 2.5 and est["k200"] != 3.0e5
    old, new = _new_bdf(), _new_bdf()
    old.read_bdf(str(tmp_path / "frame.bdf"), xref=False)
    new.read_bdf(str(out / "updated-model.bdf"), xref=False)
    assert new.materials[1].e == pytest.approx(est["E"], rel=1e-14)
    assert new.masses[101].mass == pytest.approx(est["m3"], rel=1e-14)
    assert new.elements[200].k == pytest.approx(est["k200"], rel=1e-14)
    assert new.materials[1].g == pytest.approx(old.materials[1].g * est["E"] / 2.0e11, rel=1e-13)  # nu kept
    changed = {"elements": {200}, "masses": {101}, "materials": {1}}
    for table in ("nodes", "elements", "masses", "properties", "materials"):
        a, b = getattr(old, table), getattr(new, table)
        assert set(a) == set(b)
        for key in set(a) - changed.get(table, set()):
            assert a[key].raw_fields() == b[key].raw_fields(), (table, key)
    # the deck read back is the updated model: its modes are update.json's updated_hz
    f = fp.modal_analysis(read_bdf(out / "updated-model.bdf"), 10).frequencies_hz
    for m in record["modes"]:
        assert f[m["model_mode_updated"] - 1] == pytest.approx(m["updated_hz"], rel=1e-9)


# --- (d) ambient records of a matrix model, identified and updated ---------------------------------

@pytest.fixture(scope="module")
def building(tmp_path_factory):
    """The OMA tests' 3-storey shear building as a counted matrix model, one stiffness matrix per
    storey spring, 10 % too stiff; its ambient record (oma_sim, the true building) with channels
    labelled 1, 2, 3 (DOF numbers); `femu identify --oma --model` run on it."""
    from oma_sim import STOREY_STIFFNESS, ambient_response, write_csv

    d = tmp_path_factory.mktemp("building")
    acc, f, V = ambient_response(101, 120.0, 100.0, noise=0.1)
    write_csv(d / "ambient.csv", acc, 100.0, ["1", "2", "3"])
    stiffness = []
    for i in range(3):  # storey i+1's spring joins DOF i to DOF i-1 (to the ground for storey 1)
        u = np.zeros(3)
        u[i] = 1.0
        if i:
            u[i - 1] = -1.0
        stiffness.append((f"storey{i + 1}", 1.1 * STOREY_STIFFNESS * np.outer(u, u), {"lower": 0.5, "upper": 1.5}))
    manifest = write_manifest(d, stiffness, [("M", sp.identity(3).toarray(), {})], 3, name="building",
                              file="building.json")
    assert main(["identify", str(d / "ambient.csv"), "--oma", "--model", str(manifest), "--order", "16",
                 "--out", str(d / "ident")]) == 0
    return d, manifest, f, V


def test_oma_with_dof_numbers_for_a_matrix_model(building):
    d, _, f, V = building
    doc = json.loads((d / "ident" / "modal-data.json").read_text())
    assert doc["dofs"] == [1, 2, 3] and doc["model"] == "../building.json"
    found = np.array([m["frequency_hz"] for m in doc["modes"]])
    assert np.all(np.abs(found / f - 1) < 0.005)
    for k, m in enumerate(doc["modes"]):
        s = np.array(m["shape"])
        assert (s @ V[:, k]) ** 2 / ((s @ s) * (V[:, k] @ V[:, k])) >= 0.98
        assert m["frequency_std_hz"] > 0 and len(m["shape_std"]) == 3
    assert (d / "ident" / "shapes.png").stat().st_size > 5000  # bars over the channels: no frame to draw


def test_update_takes_the_identified_deviations_as_the_noise(building, capsys):
    d, manifest, f, _ = building
    data = load_modal_data(d / "ident" / "modal-data.json")
    assert isinstance(fp.load_any_model(manifest), fp.MatrixModel)
    out = d / "upd"
    assert main(["update", str(manifest), str(d / "ident" / "modal-data.json"), "--out", str(out),
                 "--budget", "30", "--no-progress"]) == 0
    capsys.readouterr()
    record = json.loads((out / "update.json").read_text())
    assert record["noise"]["stated"] == {"frequencies": 3, "shapes": 3, "modes": 3}
    assert [m["frequency_std_hz"] for m in record["modes"]] == data.frequency_std_hz.tolist()
    assert all(m["stated_std"] for m in record["modes"])
    # the true building is the model at 1/1.1: inside each interval, and the fit is within the noise
    for p in record["parameters"]:
        lo, hi = p["interval_95"]
        assert lo < 1 / 1.1 < hi, p
    assert record["noise"]["fits_noise"] and "with the stated deviations" in record["verdict"]
    err = record["mean_abs_frequency_error_pct"]
    assert err["initial"] > 4.0 and err["updated"] < 0.05, err  # 10 % stiff: about 4.9 % before


def test_oma_labels_that_are_not_the_matrix_models_dofs(building, tmp_path, capsys):
    from oma_sim import write_csv

    d, manifest, _, _ = building
    acc = np.random.default_rng(0).standard_normal((2000, 3))
    for labels, says in ((["1", "2", "4"], "DOF number 4 is beyond model 'building'"),
                         (["2:x", "3:x", "4:x"], "numbers its DOFs 1..3: label the channels by DOF number")):
        write_csv(tmp_path / "a.csv", acc, 100.0, labels)
        line = _one_line_error(capsys, ["identify", str(tmp_path / "a.csv"), "--oma", "--model", str(manifest),
                                        "--out", str(tmp_path / "o")])
        assert "a.csv" in line and says in line, line


def test_diagnose_takes_the_matrix_models_identified_data(building, capsys):
    """`femu diagnose` on the identified modes of the building its matrix model makes 10 % too stiff
    everywhere (tests/test_diagnosis_matrix.py tests the diagnosis of matrices): the global
    stiffness scale takes it, no cause, and the record weighs by the identified deviations."""
    d, manifest, _, _ = building
    assert main(["diagnose", str(d / "ident" / "modal-data.json"), "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["cause"]["kind"] == "none" and record["extended_model"] is None
    assert record["residuals"]["global_scale"] == pytest.approx(1 / 1.1, rel=0.01)
    assert record["noise"]["data_deviations"] == {"frequencies": 3, "shapes": 3, "modes": 3}


def test_update_through_python_m_femu(building, tmp_path):
    """The same command as a user types it: exit 0, the files listed on stdout."""
    d, manifest, _, _ = building
    p = subprocess.run([sys.executable, "-m", "femu", "update", str(manifest), str(d / "ident" / "modal-data.json"),
                        "--out", str(tmp_path / "o"), "--budget", "10"], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert f"wrote {tmp_path / 'o' / 'updated-model.json'}" in p.stdout
    assert sorted(x.name for x in (tmp_path / "o").glob("*.npz")) == ["M.npz", "storey1.npz", "storey2.npz",
                                                                     "storey3.npz"]


# --- (b) a matrix model as a user's benchmark problem ---------------------------------------------

def test_femu_study_on_a_matrix_model(building, tmp_path):
    d, manifest, _, _ = building
    store, out = tmp_path / "S", tmp_path / "R"
    assert main(["study", "--model", str(manifest), "--data", str(d / "ident" / "modal-data.json"), "--optimizers",
                 "sensitivity,random-search", "--seeds", "0", "--budget", "30", "--store", str(store),
                 "--workers", "0"]) == 0
    records = [json.loads(p.read_text()) for p in sorted((store / "runs").glob("*.json"))]
    assert len(records) == 2 and all(r["status"] == "ok" and len(r["best_x"]) == 3 for r in records)
    assert all(r["problem_source"]["model"] == str(manifest.resolve()) for r in records)
    assert main(["report", str(store), "--out", str(out)]) == 0
    bench = (out / "benchmark.md").read_text()
    best = min(r["best_f"] for r in records)
    assert f"{best:.17g} | best known" in bench and "**not certified**" in bench
    assert list(out.glob("mac_*.png")) and not list(out.glob("modes_*.png"))  # no frame to draw
    # a changed matrix file (the manifest unchanged) is noticed as a changed manifest is
    from adapters.variants import make_problem
    k = sp.load_npz(d / "storey2.npz")
    try:
        sp.save_npz(d / "storey2.npz", 1.01 * k)
        with pytest.raises(ValueError, match="the model file has changed since the study recorded it"):
            make_problem(records[0]["variant"])
    finally:
        sp.save_npz(d / "storey2.npz", k)
    assert make_problem(records[0]["variant"]).n_var == 3


# --- (e) the FRF path: a matrix model's DOF labels name the channels -------------------------------

def test_identify_frfs_with_a_labelled_matrix_model(tmp_path, capsys):
    """FRFs of the H-frame identified against a matrix model whose DOF labels are the frame's
    (identification reads only the labels: K = M = I here): the same modes as against the frame,
    the data naming the manifest; a counted model, or a channel it lacks, is one line."""
    from fe_problem.identification.frf_io import write_npz

    frame = fp.load_model("hframe")
    labels = [list(d) for d in frame.dofs]
    labelled = write_manifest(tmp_path, [("K", np.eye(len(labels)), {})], [("M", np.eye(len(labels)), {})], labels,
                              name="hframe-labels", file="labelled.json")
    frfs = fp.synthetic_frf("hframe", band_hz=(5, 300), resolution_hz=1.0, noise=0.01, seed=2)
    write_npz(frfs, tmp_path / "frf.npz")
    for model, out in (("hframe", "a"), (str(labelled), "b")):
        assert main(["identify", str(tmp_path / "frf.npz"), "--model", model, "--out", str(tmp_path / out)]) == 0
    capsys.readouterr()
    a, b = (json.loads((tmp_path / o / "modal-data.json").read_text()) for o in ("a", "b"))
    assert b["model"] == "../labelled.json" and b["dofs"] == a["dofs"] and b["modes"] == a["modes"]
    counted = write_manifest(tmp_path, [("K", np.eye(4), {})], [("M", np.eye(4), {})], 4, file="counted.json")
    line = _one_line_error(capsys, ["identify", str(tmp_path / "frf.npz"), "--model", str(counted), "--out",
                                    str(tmp_path / "c")])
    assert "numbers its DOFs 1..4, and FRF files name [node, direction] coordinates" in line
    short = write_manifest(tmp_path, [("K", np.eye(3), {})], [("M", np.eye(3), {})], labels[:3], file="short.json")
    line = _one_line_error(capsys, ["identify", str(tmp_path / "frf.npz"), "--model", str(short), "--out",
                                    str(tmp_path / "d")])
    assert "frf.npz" in line and "is not one of the DOF labels of model" in line


@pytest.mark.parametrize("objective", ["balanced", "weighted"])
def test_one_parameter_with_shapes_gets_its_jacobian(objective):
    """With one parameter a Jacobian at a point whose residuals were just paid is charged 1, as
    residuals alone are: the harness says which it wants (`jacobian=`), so the sensitivity method
    runs (it failed with 'NoneType * float' before) and finds the modulus of the data."""
    import adapters

    model = fp.load_model("hframe")
    left = fp.Parameter("modulus", (1, 2, 3, 4), 5e10, 9e10, 7e10, name="left")
    data = fp.synthetic_measurement(model, 6, parameters=(left,), theta=np.array([6.44e10]), seed=1)
    kw = {"shape_weight": 1.0} if objective == "weighted" else {}
    problem = fp.UpdatingProblem(model, data, (left,), objective=objective, **kw)
    run = adapters.run("sensitivity", problem, 20, 0, x0="all")
    assert run.status == "ok", run.error
    assert run.best_x[0] == pytest.approx(6.44e10, rel=1e-6)
    ls = problem.least_squares(problem.x0, charged=1, jacobian=True)
    assert ls.jacobian is not None and ls.jacobian.shape == (ls.residuals.size, 1)
    assert problem.least_squares(problem.x0, charged=1).jacobian is None


def test_report_says_when_no_run_beat_the_start(frame3d_files, tmp_path, capsys):
    """frame3d's matrices from random starts (no x0) with a small budget: no run goes below J at
    the initial model (close modes swap far from it), so there is no best-known value; the
    report says so in one line (it said "the initial J must be above f_opt" before)."""
    d, manifest, _ = frame3d_files
    store = tmp_path / "S"
    assert main(["study", "--model", str(manifest), "--data", str(d / "matrix-data.json"), "--optimizers",
                 "sensitivity,random-search", "--seeds", "0", "--budget", "20", "--store", str(store),
                 "--workers", "0"]) == 0
    capsys.readouterr()
    best = min(json.loads(p.read_text())["best_f"] for p in (store / "runs").glob("*.json"))
    start = json.loads((d / "matrix-out" / "update.json").read_text())["objective"]["initial"]
    assert best > start
    line = _one_line_error(capsys, ["report", str(store), "--out", str(tmp_path / "R")])
    assert "no run went below the initial model's J" in line and "--x0 all" in line
