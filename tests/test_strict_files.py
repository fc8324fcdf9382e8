"""Strict schemas: a key a model or modal-data file does not define is refused with the file, the
path to the key and the closest known key; meaningless entries are refused or named
(fe_problem/jsonutil.check_keys, model/io.py, modal_data/json_format.py; docs/bad-input.md)."""

import copy
import json

import pytest

import fe_problem as fp
from fe_problem.modal_data.json_format import modal_data_to_dict
from fe_problem.model.io import KEYS, model_to_dict
from femu.cli import main

MODEL_CASES = [  # (edit of the H-frame's file, what the one error line says)
    (lambda d: d.update(suports=d.pop("supports")), ": unknown key 'suports'; did you mean 'supports'?"),
    (lambda d: d["elements"][0].update(releas_i=0.0), ": elements[0]: unknown key 'releas_i'; did you mean 'release_i'?"),
    (lambda d: d["nodes"][2].update(z=0.5), ": node 3 field 'z': a planar model's nodes lie in the x-y plane"),
    (lambda d: d["masses"].append({"node": 5, "mass_kg": 0.1, "inertia_kgm2": 1e-4}),
     ": masses[0]: unknown key 'inertia_kgm2'; did you mean 'inertia_kg_m2'?"),
    (lambda d: d["springs"].append({"id": 9, "dofs": [[5, "x"], [5, "x"]], "stiffness": 1e3}),
     ": spring 9 joins DOF [5, 'x'] to itself"),
    (lambda d: d["sections"][next(iter(d["sections"]))].update(inertia_m=1.0),
     "']: unknown key 'inertia_m'; did you mean 'inertia_m4'?"),
    (lambda d: d["materials"][next(iter(d["materials"]))].update(density=2700),
     "']: unknown key 'density'; did you mean 'density_kg_m3'?"),
    (lambda d: d["supports"].append({"node": 1, "direction": ["x"]}), ": supports[0]: unknown key 'direction'; "
                                                                     "did you mean 'directions'?"),
    (lambda d: d.update(colour="red"), ": unknown key 'colour'; the known keys are"),
]


@pytest.mark.parametrize("edit,says", MODEL_CASES, ids=[s.split("'")[1] for _, s in MODEL_CASES])
def test_femu_model_refuses_an_unknown_key_naming_file_path_and_suggestion(tmp_path, capsys, edit, says):
    d = copy.deepcopy(model_to_dict(fp.load_model("hframe")))
    edit(d)
    f = tmp_path / "m.model.json"
    f.write_text(json.dumps(d))
    assert main(["model", str(f)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert err.startswith(f"femu model: error: {f}") and says in err, err


def test_every_key_the_format_documents_is_known():
    """The docs' 3-D example (shared/formats/model-3d.md) and every field the writer emits are keys
    the reader knows: a file the project writes is always read back."""
    written = model_to_dict(fp.load_model("hframe"))
    assert set(written) <= set(KEYS["model"])
    for e in written["elements"]:
        assert set(e) <= set(KEYS["element"])
    for n in written["nodes"]:
        assert set(n) <= set(KEYS["node"])
    three_d = {"format": "femu.model/1", "name": "frame3d", "dimension": 3,
               "materials": {"steel": {"youngs_modulus_pa": 2.0e11, "shear_modulus_pa": 7.69e10,
                                       "density_kg_m3": 7850}},
               "sections": {"col": {"area_m2": 1.133e-3, "iy_m4": 1.97e-6, "iz_m4": 0.664e-6, "j_m4": 8.01e-9}},
               "nodes": [{"id": 1, "x": 0.0, "y": 0.0, "z": 0.0}, {"id": 10, "x": 0.0, "y": 0.0, "z": 0.9}],
               "elements": [{"id": 1, "nodes": [1, 10], "section": "col", "material": "steel",
                             "orientation": [1, 0, 0]}],
               "masses": [{"node": 10, "mass_kg": 88.9}],
               "supports": [{"node": 1, "directions": ["x", "y", "z", "rx", "ry", "rz"]}],
               "measured_dofs": [[10, "x"], [10, "y"]]}
    assert set(three_d) <= set(KEYS["model"])
    for table, kind in (("nodes", "node"), ("elements", "element"), ("masses", "mass"), ("supports", "support")):
        assert all(set(item) <= set(KEYS[kind]) for item in three_d[table]), table
    for table in ("materials", "sections"):
        assert all(set(v) <= set(KEYS[table]) for v in three_d[table].values()), table


DATA_CASES = [
    (lambda d: d["modes"][0].update(shapes=d["modes"][0].pop("shape")),
     "field 'modes'[0]: unknown key 'shapes'; did you mean 'shape'?"),
    (lambda d: d.update(dof=d.pop("dofs")), "unknown key 'dof'; did you mean 'dofs'?"),
    (lambda d: d.update(metadata={}), "unknown key 'metadata'; did you mean 'meta'?"),
    (lambda d: d["modes"][1].update(frequency=d["modes"][1]["frequency_hz"]),
     "field 'modes'[1]: unknown key 'frequency'; did you mean 'frequency_hz'?"),
]


@pytest.mark.parametrize("edit,says", DATA_CASES, ids=[s.split("'")[1] for _, s in DATA_CASES])
def test_femu_diagnose_refuses_an_unknown_key_in_modal_data(tmp_path, capsys, edit, says):
    d = modal_data_to_dict(fp.synthetic_measurement("hframe", n_modes=4, seed=0, model_name="hframe"))
    edit(d)
    f = tmp_path / "d.json"
    f.write_text(json.dumps(d))
    assert main(["diagnose", str(f), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err and str(f) in err and says in err, err


def test_a_mode_given_twice_is_named(tmp_path):
    d = modal_data_to_dict(fp.synthetic_measurement("hframe", n_modes=4, seed=0, model_name="hframe"))
    d["modes"].insert(2, copy.deepcopy(d["modes"][2]))
    f = tmp_path / "d.json"
    f.write_text(json.dumps(d))
    with pytest.warns(UserWarning, match=r"field 'modes'\[2\] and \[3\] are the same mode given twice"):
        fp.load_modal_data(f)
