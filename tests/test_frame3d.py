"""Space frame models end to end: 3-D model files through `fe_problem.modal_analysis` against
OpenSeesPy, the shipped example `frame3d`, the generator `regular_frame_3d` and
`femu model --frame BxBxS`.

The frames of tests/test_beam3d.py are written as real model files (the form of
docs/model-format.md), loaded with `load_model` and solved by the library's own assembly and
solver (dense and sparse paths); OpenSees builds the same frames as in test_beam3d.py (its
torsional mass mapped to rho (Iy + Iz), see there).
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.dofs import SPACE_FRAME
from femu.cli import main

from test_beam3d import FRAMES, Frame, Prop, mac_diagonal, opensees_modes

N_MODES = 10


def model_file(frame: Frame, formulation: str, path) -> str:
    """Write `frame` as a 3-D model file; returns its path."""
    props = list(dict.fromkeys(m[3] for m in frame.members))
    names = ("x", "y", "z", "rx", "ry", "rz")
    d = {
        "format": "femu.model/1", "name": "case", "dimension": 3,
        "materials": {f"m{k}": {"youngs_modulus_pa": p.E, "shear_modulus_pa": p.G, "density_kg_m3": p.rho}
                      for k, p in enumerate(props)},
        "sections": {f"s{k}": {"area_m2": p.A, "iy_m4": p.Iy, "iz_m4": p.Iz, "j_m4": p.J, "shear_coefficient": p.kappa}
                     for k, p in enumerate(props)},
        "nodes": [{"id": n, "x": x, "y": y, "z": z} for n, (x, y, z) in frame.nodes.items()],
        "elements": [{"id": eid, "nodes": [i, j], "section": f"s{props.index(p)}", "material": f"m{props.index(p)}",
                      "orientation": list(v), "formulation": formulation}
                     for eid, i, j, p, v in frame.members],
        "masses": [{"node": n, "mass_kg": kg} for n, kg in frame.masses.items()],
        "supports": [{"node": n, "directions": [d for d, f in zip(names, fix) if f]} for n, fix in frame.fixed.items()],
    }
    path.write_text(json.dumps(d))
    return str(path)


def frame_of(model: fp.FrameModel) -> Frame:
    """The test_beam3d Frame of a loaded 3-D model (for OpenSees)."""
    props = {}
    for e in model.elements:
        mat, sec = model.materials[e.material], model.sections[e.section]
        props[e.id] = Prop(E=model.element_modulus_pa(e.id), G=mat.shear_modulus * model.element_modulus_pa(e.id)
                           / mat.youngs_modulus_pa, rho=mat.density_kg_m3, A=sec.area_m2, Iy=sec.iy_m4,
                           Iz=sec.iz_m4, J=sec.j_m4, kappa=sec.shear_coefficient)
    assert not model.springs and all(m.inertia_kg_m2 == 0 for m in model.masses)
    assert all(not any(model.end_releases(e)) for e in model.elements)
    names = model.layout.names
    return Frame({n.id: (n.x, n.y, n.z) for n in model.nodes},
                 [(e.id, e.node_i, e.node_j, props[e.id], tuple(e.orientation)) for e in model.elements],
                 {s.node: tuple(int(d in s.directions) for d in names) for s in model.supports},
                 {m.node: m.mass_kg for m in model.masses})


def assert_agrees(model: fp.FrameModel, solver: str = "auto", n_modes: int = N_MODES) -> fp.ModalResult:
    timoshenko = {e.formulation for e in model.elements} == {"timoshenko"}
    ours = fp.modal_analysis(model, n_modes, solver=solver)
    f_os, s_os = opensees_modes(frame_of(model), timoshenko, n_modes)
    np.testing.assert_allclose(ours.frequencies_hz, f_os, rtol=1e-8, atol=0)
    assert mac_diagonal(ours.shapes, s_os).min() > 1 - 1e-10
    return ours


@pytest.mark.parametrize("formulation", ["euler-bernoulli", "timoshenko"])
@pytest.mark.parametrize("name", list(FRAMES))
def test_model_files_through_modal_analysis_match_opensees(name, formulation, tmp_path):
    model = fp.load_model(model_file(FRAMES[name](), formulation, tmp_path / "case.model.json"))
    assert model.layout == SPACE_FRAME
    assert {e.formulation for e in model.elements} == {formulation}
    assert_agrees(model, solver="dense")


def test_sparse_path_matches_opensees(tmp_path):
    """The portal split finely enough for the sparse path (above 200 free DOFs)."""
    model = fp.split_elements(fp.load_model(model_file(FRAMES["portal"](), "euler-bernoulli", tmp_path / "p.json")), 3)
    system = fp.AffineModel(model)
    assert system.path == "sparse" and system.n_free > 200
    assert_agrees(model)


@pytest.mark.parametrize("formulation", ["euler-bernoulli", "timoshenko"])
def test_shipped_frame3d_matches_opensees(formulation):
    model = fp.with_formulation(fp.load_model("frame3d"), formulation)
    ours = assert_agrees(model)
    assert ours.n_rigid == 0
    assert 1.0 < ours.frequencies_hz[0] < 3.0
    assert len(model.nodes) == 45 and len(model.elements) == 84 and model.n_dof == 270


def test_generator_builds_the_shipped_example():
    """`regular_frame_3d(2, 2, 4, 6, 5, 3.5)` has the shipped example's nodes, members,
    orientations, sections, material and supports (the example adds its tributary masses)."""
    shipped = fp.load_model("frame3d")
    built = fp.regular_frame_3d(2, 2, 4, 6.0, 5.0, 3.5)
    assert [(n.id, n.x, n.y, n.z) for n in built.nodes] == [(n.id, n.x, n.y, n.z) for n in shipped.nodes]
    key = [(e.id, e.node_i, e.node_j, e.section, e.material, tuple(map(float, e.orientation))) for e in built.elements]
    assert key == [(e.id, e.node_i, e.node_j, e.section, e.material, tuple(map(float, e.orientation)))
                   for e in shipped.elements]
    assert built.sections == shipped.sections and built.materials == shipped.materials
    assert built.supports == shipped.supports and built.measured_dofs == shipped.measured_dofs
    with_masses = built.replace(masses=shipped.masses)
    np.testing.assert_allclose(fp.modal_analysis(with_masses, 10).frequencies_hz,
                               fp.modal_analysis(shipped, 10).frequencies_hz, rtol=1e-12)


def test_generator_rejects_bad_sizes():
    with pytest.raises(ValueError, match="bays in y must be a whole number >= 1, got 0"):
        fp.regular_frame_3d(2, 0, 3)
    with pytest.raises(ValueError, match="storey height must be a positive number"):
        fp.regular_frame_3d(1, 1, 1, storey_height_m=-1.0)
    with pytest.raises(ValueError, match="base must be one of fixed, pinned"):
        fp.regular_frame_3d(1, 1, 1, base="roller")


def summary(capsys, *args):
    assert main(["model", *args, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_femu_model_space_frame(capsys):
    s = summary(capsys, "--frame", "2x3x4", "--floor-mass", "2000", "--bay-width", "5", "--storey-height", "3.5")
    n_nodes = 3 * 4 * 5
    assert (s["n_nodes"], s["n_dofs"], s["n_free_dofs"]) == (n_nodes, 6 * n_nodes, 6 * (n_nodes - 12))
    assert s["n_elements"] == 4 * (12 + 2 * 4 + 3 * 3) and s["masses"] == 48 and s["n_rigid_modes"] == 0
    assert s["name"] == "frame2x3x4" and s["solver_path"] == "sparse"
    direct = fp.regular_frame_3d(2, 3, 4, 5.0, 5.0, 3.5, floor_mass_kg=2000.0)
    np.testing.assert_allclose(s["frequencies_hz"], fp.modal_analysis(direct, 10, solver="dense").frequencies_hz,
                               rtol=1e-8)


def test_femu_model_shipped_frame3d_and_bad_frame_text(capsys):
    s = summary(capsys, "frame3d")
    np.testing.assert_allclose(s["frequencies_hz"], fp.modal_analysis("frame3d", 10).frequencies_hz, rtol=1e-12)
    for bad in ("2x2x0", "2x2x4x1", "2xx4"):
        with pytest.raises(SystemExit) as exc:
            main(["model", "--frame", bad])
        assert exc.value.code == 2
        assert "BAYSxBAYSxSTOREYS" in capsys.readouterr().err


def test_femu_model_pinned_space_frame_saves_and_reloads(tmp_path, capsys):
    path = tmp_path / "s.model.json"
    assert main(["model", "--frame", "1x1x2", "--base", "pinned", "--save", str(path)]) == 0
    capsys.readouterr()
    again = fp.load_model(path)
    assert again.layout == SPACE_FRAME and len(again.nodes) == 12
    assert all(s.directions == ("x", "y", "z") for s in again.supports)
    np.testing.assert_allclose(fp.modal_analysis(again, 6).frequencies_hz,
                               fp.modal_analysis(fp.regular_frame_3d(1, 1, 2, base="pinned"), 6).frequencies_hz,
                               rtol=1e-12)
