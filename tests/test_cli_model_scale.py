"""`femu model` on generated and split models: size, solver path, timings, --save, bad arguments.

The frequencies of the sparse path are checked against the dense path forced on the same
model (--solver dense), and a split model's against a finer split (convergence)."""

import json
import subprocess
import sys

import numpy as np
import pytest

import fe_problem as fp
from femu.cli import main


def summary(capsys, *args):
    assert main(["model", *args, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_generated_frame_size(capsys):
    s = summary(capsys, "--frame", "3x4", "--floor-mass", "500")
    assert (s["n_nodes"], s["n_elements"], s["n_dofs"], s["n_free_dofs"]) == (20, 28, 60, 48)
    assert s["solver_path"] == "dense" and s["masses"] == 16 and s["n_rigid_modes"] == 0
    assert s["name"] == "frame3x4" and len(s["frequencies_hz"]) == 10
    assert all(s[k] >= 0 for k in ("build_s", "assemble_s", "solve_s"))
    direct = fp.modal_analysis(fp.regular_frame(3, 4, floor_mass_kg=500.0), 10).frequencies_hz
    np.testing.assert_allclose(s["frequencies_hz"], direct, rtol=1e-12)


def test_split_hframe_takes_the_sparse_path_and_agrees_with_dense(capsys):
    sparse = summary(capsys, "hframe", "--split", "8", "--modes", "8")
    dense = summary(capsys, "hframe", "--split", "8", "--modes", "8", "--solver", "dense")
    assert sparse["solver_path"] == "sparse" and dense["solver_path"] == "dense"
    assert sparse["n_nodes"] == 13 + 12 * 7 and sparse["n_elements"] == 12 * 8 and sparse["n_rigid_modes"] == 3
    assert sparse["name"] == "hframe-split8" and sparse["n_free_dofs"] == 3 * (13 + 12 * 7)
    np.testing.assert_allclose(sparse["frequencies_hz"], dense["frequencies_hz"], rtol=1e-8)
    # a free-free frame has exactly three rigid-body modes however finely it is split, and the
    # split converges: split 4 and split 16 near the same limit, 16 closer to 8 than 4 is
    fine = summary(capsys, "hframe", "--split", "16", "--modes", "8")
    coarse = summary(capsys, "hframe", "--split", "4", "--modes", "8")["frequencies_hz"]
    assert fine["n_rigid_modes"] == 3
    np.testing.assert_allclose(coarse, fine["frequencies_hz"], rtol=2e-3)
    assert (np.abs(np.subtract(fine["frequencies_hz"], sparse["frequencies_hz"]))
            <= np.abs(np.subtract(coarse, sparse["frequencies_hz"]))).all()


def test_save_round_trip_and_text_output(tmp_path, capsys):
    path = tmp_path / "big.model.json"
    assert main(["model", "--frame", "2x5", "--split", "2", "--base", "pinned", "--save", str(path)]) == 0
    out = capsys.readouterr().out
    assert f"saved to {path}" in out and "free DOFs, dense solver; built in" in out
    assert "43 nodes, 50 elements (euler-bernoulli), 129 DOFs" in out
    model = fp.load_model(path)
    assert model == fp.split_elements(fp.regular_frame(2, 5, base="pinned"), 2).replace(
        name=model.name, description=model.description)
    again = summary(capsys, str(path))
    assert again["n_free_dofs"] == 129 - 3 * 2 and again["name"] == "frame2x5-split2"


@pytest.mark.parametrize("args, says", [
    (["hframe", "--frame", "2x3"], "give a MODEL (a shipped name or a model file) or --frame BAYSxSTOREYS, not both"),
    (["--frame", "3y4"], "--frame: expected BAYSxSTOREYS"),
    (["--frame", "0x4"], "--frame: expected BAYSxSTOREYS"),
    (["hframe", "--split", "0"], "--split: must be at least 1"),
    (["--frame", "2x2", "--bay-width", "-1"], "--bay-width: must be a finite number > 0"),
    (["--frame", "2x2", "--storey-height", "inf"], "--storey-height: must be a finite number > 0"),
    (["--frame", "2x2", "--floor-mass", "nan"], "--floor-mass: must be a finite number >= 0"),
    (["--frame", "2x2", "--base", "roller"], "--base: invalid choice"),
    (["hframe", "--solver", "fast"], "--solver: invalid choice"),
    (["hframe", "--floor-mass", "100"], "--floor-mass describes a generated frame: give --frame BAYSxSTOREYS"),
    (["CRACKED", "--split", "2"], "crack at 0.5 of the length falls on a boundary between parts"),
])
def test_bad_arguments_one_line_exit_2(tmp_path, args, says):
    cracked = tmp_path / "cracked.model.json"
    fp.save_model(fp.crack_element(fp.load_model("hframe"), 4, 0.5, 1e4), cracked)
    args = [str(cracked) if a == "CRACKED" else a for a in args]
    p = subprocess.run([sys.executable, "-m", "femu", "model", *args], cwd=tmp_path, capture_output=True,
                       text=True, timeout=120)
    lines = [ln for ln in p.stderr.splitlines() if ln.startswith("femu")]
    assert p.returncode == 2 and "Traceback" not in p.stderr and len(lines) == 1, p.stderr
    assert "error:" in lines[0] and says in lines[0], lines[0]
    assert sorted(x.name for x in tmp_path.iterdir()) == ["cracked.model.json"]
