"""`femu model`: the summary a user sees, for the shipped H-frame and for a model file."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import fe_problem as fp
from femu.cli import main

FEMU = Path(sys.executable).with_name("femu")
# docs/hframe.md, nominal elastic frequencies, modes 1-10
HFRAME_MD_HZ = [56.287, 127.217, 228.388, 263.523, 452.854, 658.509, 1043.033, 1248.947, 1442.207, 1813.389]
# hframe.md lists three decimals (+-5e-4 Hz) of the frequencies of the exact 9.8 x 32.2 mm
# section; the shipped file stores I to six figures (dI/I = 1.3e-6), which moves bending
# frequencies by at most half that (see tests/test_opensees.py::test_reference_frequencies_of_hframe_md)
MD_ATOL, SHIPPED_RTOL = 5e-4, 7e-7


def run_json(capsys, *args):
    assert main(["model", *args, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_model_hframe_text(capsys):
    assert main(["model", "hframe"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("model hframe  (")
    assert "13 nodes, 12 elements (euler-bernoulli), 39 DOFs, mass 1.7722 kg" in out
    assert "3 rigid-body modes dropped" in out and "15 measured DOFs; excitation (5, 'x')" in out
    rows = [line.split() for line in out.splitlines() if line.strip()[:1].isdigit() and len(line.split()) == 2]
    assert [int(r[0]) for r in rows] == list(range(1, 11))
    # printed with three decimals too: two roundings
    np.testing.assert_allclose([float(r[1]) for r in rows], HFRAME_MD_HZ, rtol=SHIPPED_RTOL, atol=2 * MD_ATOL)


def test_model_hframe_json(capsys):
    summary = run_json(capsys, "hframe")
    assert summary["name"] == "hframe" and summary["n_nodes"] == 13 and summary["n_elements"] == 12
    assert summary["n_dofs"] == 39 and summary["n_rigid_modes"] == 3
    assert summary["total_mass_kg"] == pytest.approx(1.772, abs=5e-4)
    assert summary["formulations"] == ["euler-bernoulli"]
    assert summary["measured_dofs"][:2] == [[1, "x"], [2, "x"]] and len(summary["measured_dofs"]) == 15
    assert summary["excitation"] == [5, "x"]
    np.testing.assert_allclose(summary["frequencies_hz"], HFRAME_MD_HZ, rtol=SHIPPED_RTOL, atol=MD_ATOL)


def test_model_modes_option(capsys):
    summary = run_json(capsys, "hframe", "--modes", "4")
    assert len(summary["frequencies_hz"]) == 4
    np.testing.assert_allclose(summary["frequencies_hz"], HFRAME_MD_HZ[:4], rtol=SHIPPED_RTOL, atol=MD_ATOL)


def test_model_file(tmp_path, capsys):
    hframe = fp.load_model("hframe")
    model = fp.release_element_end(fp.add_mass(fp.split_element(hframe, 4, 0.37, 3e4), 5, 0.15), 5, 3, 1e5)
    model = fp.with_formulation(model.replace(name="cracked-hframe", description="a test variant"), "timoshenko")
    path = fp.save_model(model, tmp_path / "cracked.json")
    summary = run_json(capsys, str(path))
    assert summary["name"] == "cracked-hframe" and summary["source"] == str(path)
    assert summary["description"] == "a test variant"
    assert (summary["n_nodes"], summary["n_elements"], summary["masses"]) == (14, 13, 1)
    assert summary["formulations"] == ["timoshenko"]
    assert summary["total_mass_kg"] == pytest.approx(hframe.total_mass_kg() + 0.15)
    expected = fp.modal_analysis(model, 10).frequencies_hz
    np.testing.assert_allclose(summary["frequencies_hz"], expected, rtol=1e-12)
    assert np.all(np.array(summary["frequencies_hz"]) < np.array(HFRAME_MD_HZ))


def test_unknown_model_name(capsys):
    assert main(["model", "hframes"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("femu model: error:")
    assert "'hframes'" in err and "shipped: frame3d, hframe" in err


def test_bad_model_file(tmp_path, capsys):
    path = tmp_path / "bad.json"
    d = json.loads(fp.save_model(fp.load_model("hframe"), path).read_text())
    d["elements"][0]["nodes"] = [1, 42]
    path.write_text(json.dumps(d))
    assert main(["model", str(path)]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "element 1" in err and "unknown node 42" in err


def test_femu_command_end_to_end():
    ok = subprocess.run([str(FEMU), "model", "hframe", "--json"], capture_output=True, text=True, timeout=120)
    assert ok.returncode == 0, ok.stderr
    np.testing.assert_allclose(json.loads(ok.stdout)["frequencies_hz"], HFRAME_MD_HZ, rtol=SHIPPED_RTOL, atol=MD_ATOL)
    bad = subprocess.run([str(FEMU), "model", "no-such-frame"], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and bad.stdout == ""
    assert "no-such-frame" in bad.stderr and "shipped: frame3d, hframe" in bad.stderr


def _propped_cantilever(tmp_path):
    """A model file with only 4 free DOFs (so 4 elastic modes): two elements, node 1 clamped,
    node 3 pinned."""
    doc = {
        "format": "femu.model/1", "name": "propped", "description": "two-element propped cantilever",
        "materials": {"steel": {"youngs_modulus_pa": 2.1e11, "density_kg_m3": 7850.0}},
        "sections": {"bar": {"area_m2": 1e-4, "inertia_m4": 1e-9}},
        "nodes": [{"id": 1, "x": 0.0, "y": 0.0}, {"id": 2, "x": 0.5, "y": 0.0}, {"id": 3, "x": 1.0, "y": 0.0}],
        "elements": [{"id": 1, "nodes": [1, 2], "section": "bar", "material": "steel"},
                     {"id": 2, "nodes": [2, 3], "section": "bar", "material": "steel"}],
        "supports": [{"node": 1, "directions": ["x", "y", "rz"]}, {"node": 3, "directions": ["x", "y"]}],
    }
    path = tmp_path / "propped.model.json"
    path.write_text(json.dumps(doc))
    return path


def test_model_with_fewer_modes_than_asked(tmp_path, capsys):
    path = _propped_cantilever(tmp_path)
    expected = fp.modal_analysis(fp.load_model(path), 4).frequencies_hz
    with pytest.raises(ValueError, match="only 4 elastic modes, asked for 10"):
        fp.modal_analysis(fp.load_model(path), 10)  # the API stays strict unless asked not to be
    assert main(["model", str(path)]) == 0  # --modes defaults to 10
    out = capsys.readouterr().out
    assert "the model has only 4 elastic modes (asked for 10)" in out
    assert "3 nodes, 2 elements (euler-bernoulli), 9 DOFs" in out
    rows = [line.split() for line in out.splitlines() if line.strip()[:1].isdigit() and len(line.split()) == 2]
    assert [int(r[0]) for r in rows] == [1, 2, 3, 4]
    np.testing.assert_allclose([float(r[1]) for r in rows], expected, rtol=1e-3)
    summary = run_json(capsys, str(path), "--modes", "7")
    assert summary["n_dofs"] == 9 and summary["n_rigid_modes"] == 0
    np.testing.assert_array_equal(summary["frequencies_hz"], expected)
