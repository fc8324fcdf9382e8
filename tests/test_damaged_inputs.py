"""Damaged and odd input files: each is refused with one line naming the file (and the line,
field or mode), or read with a warning that names what was lost, or gives the same answer as
the undamaged file. Never a traceback, never silently fewer modes.

The corpus is made here from files the project writes: an 8-mode UFF 55 file of a cracked
H-frame cut after every one of its lines and in the middle of lines, with a damaged dataset
number, with its last delimiter removed; JSON data with shapes scaled by 1e308 and 1e-320,
with numbers too large to hold; a data file whose model is a user's model file."""

from __future__ import annotations

import dataclasses
import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.modal_data import DataFileError, save_modal_data
from femu.cli import main


@pytest.fixture(scope="module")
def crack(tmp_path_factory):
    d = tmp_path_factory.mktemp("damaged")
    truth = fp.crack_element(fp.load_model("hframe"), 7, 0.3, 3e4)
    data = fp.synthetic_measurement(truth, n_modes=8, freq_noise=0.002, shape_noise=0.02, seed=1, model_name="hframe")
    save_modal_data(data, d / "crack.uff")
    save_modal_data(data, d / "crack.json")
    return d


def _uff_lines(crack) -> list[str]:
    return (crack / "crack.uff").read_text().split("\n")


def _complete_datasets(lines: list[str]) -> int:
    """Datasets 55 whose opening and closing delimiters both lie in `lines`."""
    delims = [i for i, line in enumerate(lines) if line.strip() == "-1"]
    return sum(1 for a, b in zip(delims[::2], delims[1::2]) if lines[a + 1].split()[0] == "55")


N_LINES = 297  # of the 8-mode file (checked below)


def test_the_corpus_file_is_what_the_cuts_assume(crack):
    lines = _uff_lines(crack)
    assert len(lines) == N_LINES and _complete_datasets(lines) == 8
    assert fp.load_modal_data(crack / "crack.uff").n_modes == 8


@pytest.mark.parametrize("n", range(1, N_LINES - 1))
def test_a_uff_file_cut_after_any_line_is_refused_or_read_whole_to_its_last_complete_mode(crack, tmp_path, n):
    lines = _uff_lines(crack)
    cut = tmp_path / "cut.uff"
    cut.write_text("\n".join(lines[:n]) + "\n")
    complete = _complete_datasets(lines[:n])
    inside = sum(1 for line in lines[:n] if line.strip() == "-1") % 2 == 1
    if inside or complete == 0:
        with pytest.raises(DataFileError, match=str(cut)):
            fp.load_modal_data(cut)
    else:  # cut exactly between two datasets: a whole, valid file of fewer modes (nothing to detect)
        assert fp.load_modal_data(cut).n_modes == complete


@pytest.mark.parametrize("n", [40, 100, 151, 170, 200, 260, 290])
def test_a_uff_file_cut_in_the_middle_of_a_line_is_refused(crack, tmp_path, n):
    lines = _uff_lines(crack)
    cut = tmp_path / "cut.uff"
    cut.write_text("\n".join(lines[:n]) + "\n" + lines[n][: len(lines[n]) // 2])
    with pytest.raises(DataFileError, match="never closed|no type number"):
        fp.load_modal_data(cut)
    assert main(["diagnose", str(cut)]) == 2


def test_a_uff_file_without_its_last_delimiter_is_refused(crack, tmp_path, capsys):
    lines = _uff_lines(crack)
    last = max(i for i, line in enumerate(lines) if line.strip() == "-1")
    bad = tmp_path / "nolast.uff"
    bad.write_text("\n".join(lines[:last] + lines[last + 1:]))
    assert main(["diagnose", str(bad)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and str(bad) in err and "never closed" in err


def test_a_damaged_dataset_number_is_refused_or_named_as_ignored(crack, tmp_path, capsys):
    lines = _uff_lines(crack)
    heads = [i + 1 for i, line in enumerate(lines) if line.strip() == "-1"][::2]
    letters = tmp_path / "letters.uff"
    letters.write_text("\n".join(line.replace("55", "5x") if i == heads[4] else line for i, line in enumerate(lines)))
    with pytest.raises(DataFileError, match=f"line {heads[4] + 1}: .* no type number"):
        fp.load_modal_data(letters)
    other = tmp_path / "other.uff"
    other.write_text("\n".join(line.replace("55", "58") if i == heads[4] else line for i, line in enumerate(lines)))
    with pytest.warns(UserWarning, match=r"ignored 1 dataset\(s\) of type\(s\) \[58\] among the 7 datasets 55"):
        assert fp.load_modal_data(other).n_modes == 7
    main(["diagnose", str(other), "--json"])
    err = capsys.readouterr().err
    assert err.startswith(f"femu: warning: {other}: ignored 1 dataset") and "Traceback" not in err


@pytest.mark.parametrize("scale", [1e308, 1e-320, -3.0, 1e-300, 1e300])
def test_a_shape_scale_changes_nothing(crack, tmp_path, scale):
    d = json.loads((crack / "crack.json").read_text())
    mode = d["modes"][2]
    top = max(abs(v) for v in mode["shape"])
    mode["shape"] = [v / top * scale for v in mode["shape"]]  # the largest entry becomes `scale`
    scaled = tmp_path / "scaled.json"
    scaled.write_text(json.dumps(d))
    p0, p1 = fp.UpdatingProblem("hframe", crack / "crack.json"), fp.UpdatingProblem("hframe", scaled)
    x = p0.x0 * np.linspace(0.95, 1.05, p0.n_var)
    rtol = 1e-3 if abs(scale) < 1e-307 else 1e-12  # a subnormal keeps only a few digits of the shape
    np.testing.assert_allclose(p1.evaluate(x), p0.evaluate(x), rtol=rtol)
    c0, c1 = p0.correlation(x), p1.correlation(x)
    assert np.array_equal(c0.model_hz, c1.model_hz)
    np.testing.assert_allclose(c1.mac, c0.mac, rtol=rtol)


def test_a_diagnosis_does_not_drop_a_mode_whose_shape_is_scaled_by_1e308(crack, tmp_path, capsys):
    d = json.loads((crack / "crack.json").read_text())
    top = max(abs(v) for v in d["modes"][2]["shape"])
    d["modes"][2]["shape"] = [v / top * 1e308 for v in d["modes"][2]["shape"]]
    scaled = tmp_path / "scaled.json"
    scaled.write_text(json.dumps(d))
    answers = []
    for f in (crack / "crack.json", scaled):
        assert main(["diagnose", str(f), "--json"]) == 0
        rec = json.loads(capsys.readouterr().out)
        answers.append((rec["cause"]["kind"], rec["cause"]["location"], rec["residuals"]["unpaired_modes"]))
    assert answers[0] == answers[1] == ("stiffness_loss", {"element": 7}, [])


@pytest.mark.parametrize("field,value,says", [
    ("frequency_hz", int("9" * 400), "an integer of 400 digits"),
    ("frequency_hz", -1, "must be a finite number > 0"),
    ("frequency_hz", "53", "must be a finite number > 0"),
    ("shape", [int("9" * 400)] * 15, "shape[0]: must be a finite number"),
    ("shape", [0.0] * 15, "all zeros"),
    ("shape", 7, "needs 15 numbers"),
])
def test_a_bad_mode_field_is_named(crack, tmp_path, capsys, field, value, says):
    d = json.loads((crack / "crack.json").read_text())
    d["modes"][3][field] = value
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(d))
    with pytest.raises(DataFileError, match="modes'\\]?\\[3\\]"):
        fp.load_modal_data(bad)
    assert main(["diagnose", str(bad)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and str(bad) in err and says in err, err


def test_data_whose_model_is_a_users_model_file_are_accepted(tmp_path, capsys, monkeypatch):
    model = dataclasses.replace(fp.load_model("hframe"), name="my-frame")  # a name other than the file's
    fp.save_model(model, tmp_path / "myframe.model.json")
    truth = fp.crack_element(model, 7, 0.3, 3e4)
    data = fp.synthetic_measurement(truth, n_modes=8, freq_noise=0.002, shape_noise=0.02, seed=1,
                                    model_name="myframe.model.json")
    save_modal_data(data, tmp_path / "data.json")
    monkeypatch.chdir(tmp_path.parent)  # the model path is relative to the data file, not to here
    for extra in ([], ["--model", str(tmp_path / "myframe.model.json")]):
        assert main(["diagnose", str(tmp_path / "data.json"), "--json", *extra]) == 0
        rec = json.loads(capsys.readouterr().out)
        assert rec["cause"]["kind"] == "stiffness_loss" and rec["cause"]["location"] == {"element": 7}
    assert fp.UpdatingProblem(tmp_path / "myframe.model.json", tmp_path / "data.json").n_var == 12


# -- physics that cannot be solved, named where ------------------------------------------------------
def _hframe_dict():
    from fe_problem.model import model_to_dict

    return model_to_dict(fp.load_model("hframe"))


def test_a_node_connected_to_nothing_is_named(tmp_path, capsys):
    d = _hframe_dict()
    d["nodes"].append({"id": 99, "x": 2.0, "y": 2.0})
    d["masses"] = [{"node": 99, "mass_kg": 1.0, "inertia_kg_m2": 1e-3}]
    f = tmp_path / "loose.model.json"
    f.write_text(json.dumps(d))
    assert main(["model", str(f)]) == 2
    err = capsys.readouterr().err
    assert err == f"femu model: error: {f}: node 99 is connected to no element and no spring: remove it or connect it\n"


def test_a_dof_without_mass_is_named(tmp_path, capsys):
    d = _hframe_dict()
    for e in d["elements"]:  # a pin between elements 1 and 2: node 2's rotation belongs to no element end
        if e["id"] == 1:
            e["release_j"] = 0.0
        if e["id"] == 2:
            e["release_i"] = 0.0
    f = tmp_path / "pin.model.json"
    f.write_text(json.dumps(d))
    assert main(["model", str(f)]) == 2
    err = capsys.readouterr().err
    # a DOF without mass is solved exactly since issue 36 (lumped mass); one that nothing stiff holds
    # either has no mode, and is named
    assert len(err.strip().splitlines()) == 1 and f"{f}: node 2 rz can move without mass and without straining" in err


def test_a_mechanism_is_shown_with_what_moves(capsys):
    model = fp.release_element_end(fp.load_model("hframe"), 5, 3, 0.0)  # the crossbar pinned to the left upright
    res = fp.modal_analysis(model)
    assert res.n_rigid == 4 and res.mechanism.startswith("1 mechanism motion(s) strain no element and no spring")
    assert "node 3 rz" in res.mechanism
    assert fp.modal_analysis("hframe").mechanism is None
    from fe_problem.model import Support

    supported = model.replace(supports=(Support(1, ("x", "y")),))  # pinned at a foot: 1 rigid + 1 mechanism
    assert fp.modal_analysis(supported).n_rigid == 2 and fp.modal_analysis(supported).mechanism.startswith("1 mech")


MODEL_EDITS = [
    (lambda d: d["elements"][0].__setitem__("section", ["a"]), "elements[0] field 'section': must be the name"),
    (lambda d: d["elements"][0].__setitem__("material", {"a": 1}), "elements[0] field 'material': must be the name"),
    (lambda d: d.__setitem__("masses", 5), "field 'masses' must be a list, got 5"),
    (lambda d: d.__setitem__("measured_dofs", 7), "field 'measured_dofs' must be a list, got 7"),
    (lambda d: d.__setitem__("supports", [3]), "supports[0] must be an object, got 3"),
    (lambda d: d["nodes"][3].__setitem__("x", 1e300), "node 4 field 'x' must be a finite number of metres"),
    (lambda d: d["nodes"][3].__setitem__("x", int("9" * 400)), "got an integer of 400 digits"),
    (lambda d: d["materials"]["aluminium"].__setitem__("youngs_modulus_pa", 1e-300), "outside the physical range"),
    (lambda d: d["materials"]["aluminium"].__setitem__("youngs_modulus_pa", 1e300), "outside the physical range"),
    (lambda d: d["materials"]["aluminium"].__setitem__("density_kg_m3", 1e300), "outside the physical range"),
    (lambda d: d["sections"]["bar"].__setitem__("area_m2", 1e-300), "outside the physical range"),
    (lambda d: d["sections"]["bar"].__setitem__("inertia_m4", 1e300), "outside the physical range"),
]


@pytest.mark.parametrize("edit,says", MODEL_EDITS, ids=[s for _, s in MODEL_EDITS])
def test_a_model_field_of_the_wrong_type_or_range_is_named(tmp_path, capsys, edit, says):
    d = _hframe_dict()
    edit(d)
    f = tmp_path / "bad.model.json"
    f.write_text(json.dumps(d))
    with pytest.raises(fp.ModelFileError):
        fp.load_model(f)
    assert main(["model", str(f)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and str(f) in err and says in err and "Traceback" not in err, err
