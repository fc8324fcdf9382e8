"""Space models through the plumbing (issue 24, step 2): model files with springs, masses,
releases and measured DOFs in x, y, z and the rotations; modal data (JSON, UFF 55) and FRF
files (UFF 58, npz, CSV) with the six directions, checked against the model's layout; the
dense and sparse paths against OpenSeesPy; `femu model` on a space model file.

The elements are the test-only formulations of space_elements.py (a bar; a bar with torsion),
checked against closed forms and OpenSeesPy's 3-D truss; the real space-frame elements are
another branch's.
"""

from __future__ import annotations

import json

import numpy as np
import openseespy.opensees as ops
import pytest
import scipy.linalg

import fe_problem as fp
import space_elements  # noqa: F401  (registers the test-only 3-D formulations)
from femu import cli
from fe_problem.identification import FRFFileError, read_frf
from fe_problem.modal_data.uff import read_uff55
from fe_problem.terms import DofMap, release_rotation

STEEL = {"youngs_modulus_pa": 2.0e11, "shear_modulus_pa": 7.69e10, "density_kg_m3": 7850}
SEC = {"area_m2": 1.133e-3, "iy_m4": 1.97e-6, "iz_m4": 0.664e-6, "j_m4": 8.01e-9}
ROT = ["rx", "ry", "rz"]


def space_dict(nodes, elements, supports=(), masses=(), springs=(), measured=(), excitation=None, name="space"):
    """A model file's JSON as an outside script writes it (model-3d.md)."""
    d = {"format": "femu.model/1", "name": name, "dimension": 3, "materials": {"steel": dict(STEEL)},
         "sections": {"s": dict(SEC)}, "nodes": [{"id": n, "x": x, "y": y, "z": z} for n, x, y, z in nodes],
         "elements": [dict({"id": k + 1, "nodes": [i, j], "section": "s", "material": "steel",
                            "orientation": o, "formulation": f}, **extra)
                      for k, (i, j, o, f, extra) in enumerate(elements)],
         "masses": [dict(m) for m in masses], "supports": [{"node": n, "directions": d} for n, d in supports],
         "springs": [dict(s) for s in springs], "measured_dofs": [list(m) for m in measured]}
    if excitation:
        d["excitation"] = list(excitation)
    return d


def tower(tmp_path=None):
    """A braced square tower of bars, 2 storeys, fixed at its base: every DOF of it moves in
    3-D; each node's rotations supported (a pin-jointed truss)."""
    nodes, k = [], 1
    for s in range(3):
        for x, y in ((0, 0), (2, 0), (2, 2), (0, 2)):
            nodes.append((k, float(x), float(y), 2.5 * s))
            k += 1
    pairs = []
    for s in range(2):
        for c in range(4):
            a, b = 4 * s + c + 1, 4 * s + (c + 1) % 4 + 1
            pairs += [(a, a + 4), (a + 4, b + 4), (a, b + 4)]      # column, ring beam, brace
        pairs.append((4 * s + 5, 4 * s + 7))                       # floor diagonal
    elements = [(i, j, [0.3, 0.7, 0.1], "test-space-bar", {}) for i, j in pairs]
    supports = [(n, ["x", "y", "z"] + ROT if n <= 4 else ROT) for n, *_ in nodes]
    d = space_dict(nodes, elements, supports, masses=[{"node": 10, "mass_kg": 30.0}],
                   springs=[{"id": 1, "dofs": [[12, "z"]], "stiffness": 5e5}],
                   measured=[(n, d) for n in (9, 10, 11, 12) for d in ("x", "y", "z")], excitation=(11, "z"),
                   name="tower")
    if tmp_path is None:
        return fp.model.model_from_dict(d, "tower")
    path = tmp_path / "tower.model.json"
    path.write_text(json.dumps(d))
    return fp.load_model(path)


def opensees_truss(model: fp.FrameModel, n_modes: int) -> np.ndarray:
    """The same truss in OpenSees (ndm 3, ndf 3: Truss elements with consistent mass)."""
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 3)
    for n in model.nodes:
        ops.node(n.id, n.x, n.y, n.z)
    for s in model.supports:
        fixed = [int(d in s.directions) for d in ("x", "y", "z")]
        if any(fixed):
            ops.fix(s.node, *fixed)
    for e in model.elements:
        sec, mat = model.sections[e.section], model.materials[e.material]
        ops.uniaxialMaterial("Elastic", e.id, model.element_modulus_pa(e.id))
        ops.element("Truss", e.id, e.node_i, e.node_j, sec.area_m2, e.id, "-rho",
                    mat.density_kg_m3 * sec.area_m2, "-cMass", 1)
    for lm in model.masses:
        ops.mass(lm.node, lm.mass_kg, lm.mass_kg, lm.mass_kg)
    tag = 10_000
    for sp in model.springs:  # a spring to ground: a zeroLength to a fixed twin node
        ops.node(tag, *model.coordinates[model.node_position(sp.dof_a[0])])
        ops.fix(tag, 1, 1, 1)
        ops.uniaxialMaterial("Elastic", tag, sp.stiffness)
        ops.element("zeroLength", tag, tag, sp.dof_a[0], "-mat", tag, "-dir", "xyz".index(sp.dof_a[1]) + 1)
        tag += 1
    lam = np.array(ops.eigen("-fullGenLapack", n_modes))
    ops.wipe()
    return np.sqrt(lam) / (2 * np.pi)


def test_space_truss_frequencies_match_opensees_on_both_paths():
    m = tower()
    assert m.layout.dimension == 3 and m.n_dof == 72
    for solver in ("dense", "sparse"):
        res = fp.modal_analysis(m, 12, solver=solver)
        assert res.n_rigid == 0 and res.mechanism is None
        np.testing.assert_allclose(res.frequencies_hz, opensees_truss(m, 12), rtol=1e-8)
    # updated moduli: the parameters scale each bar's stiffness
    pars = fp.element_moduli(m, lower=1.5e11, upper=2.5e11)
    theta = np.random.default_rng(5).uniform(1.5e11, 2.5e11, len(pars))
    res = fp.modal_analysis(m, 12, parameters=pars, theta=theta)
    updated = m.with_element_moduli(dict(zip(m.element_ids, theta)))
    np.testing.assert_allclose(res.frequencies_hz, opensees_truss(updated, 12), rtol=1e-8)


def test_space_model_file_round_trips_with_every_direction(tmp_path):
    m = tower(tmp_path)
    assert m.springs[0].dof_a == (12, "z") and m.excitation == (11, "z")
    again = fp.load_model(fp.save_model(m, tmp_path / "again.model.json"))
    assert again == m
    np.testing.assert_array_equal(fp.modal_analysis(again, 6).frequencies_hz, fp.modal_analysis(m, 6).frequencies_hz)
    # a lumped mass acts in x, y and z
    base = fp.modal_analysis(m.replace(masses=()), 24)
    heavy = fp.modal_analysis(m, 24)
    assert np.all(heavy.frequencies_hz <= base.frequencies_hz) and np.any(heavy.frequencies_hz < base.frequencies_hz)
    k, mm = fp.AffineModel(m, solver="dense").stiffness(np.zeros((1, 0)))[0], \
        fp.AffineModel(m, solver="dense").mass(np.zeros((1, 0)))[0]
    k0, m0 = (fp.AffineModel(m.replace(masses=()), solver="dense").stiffness(np.zeros((1, 0)))[0],
              fp.AffineModel(m.replace(masses=()), solver="dense").mass(np.zeros((1, 0)))[0])
    np.testing.assert_array_equal(k, k0)
    assert np.count_nonzero(mm - m0) == 3 and np.allclose(np.diag(mm - m0)[np.diag(mm - m0) != 0], 30.0)


def torsion_model(release=None, skew=False, orientation=(0.0, 0.0, 1.0)):
    """A rod from node 1 (clamped) to node 2 (free along and about its axis; a mass with rotary
    inertia there); with `release`, its end at node 1 tied by a torsional spring."""
    end = (1.2, 0.9, 0.0) if skew else (1.5, 0.0, 0.0)
    extra = {} if release is None else {"releases_i": {"rx": release}}
    free = ["x", "rx"] if not skew else []
    d = space_dict([(1, 0.0, 0.0, 0.0), (2, *end)], [(1, 2, list(orientation), "test-space-rod", extra)],
                   supports=[(1, ["x", "y", "z"] + ROT), (2, [c for c in ["x", "y", "z"] + ROT if c not in free])],
                   masses=[{"node": 2, "mass_kg": 4.0, "inertia_kg_m2": 0.02}], name="rod")
    return fp.model.model_from_dict(d, "rod.model.json")


def test_a_torsional_release_is_a_spring_in_series_with_the_rod():
    length, g, e = 1.5, STEEL["shear_modulus_pa"], STEEL["youngs_modulus_pa"]
    k_t = g * SEC["j_m4"] / length
    polar = 7850 * (SEC["iy_m4"] + SEC["iz_m4"]) * length / 6
    axial = np.sqrt(e * SEC["area_m2"] / length / (7850 * SEC["area_m2"] * length / 3 + 4.0)) / (2 * np.pi)
    rigid = fp.modal_analysis(torsion_model(), 2).frequencies_hz
    torsion = np.sqrt(k_t / (2 * polar + 0.02)) / (2 * np.pi)  # one DOF: theta_2, mass 2 polar + I
    np.testing.assert_allclose(np.sort(rigid), np.sort([axial, torsion]), rtol=1e-12)
    for k_r in (0.3 * k_t, 5.0 * k_t):
        m = torsion_model(release=k_r)
        dm = DofMap.of(m)
        assert list(dm.hinges) == [(1, 1)] and list(dm.hinges[(1, 1)]) == ["rx"]
        # the hinge (the rod's own end rotation) and theta_2, assembled by hand
        kk = np.array([[k_t + k_r, -k_t], [-k_t, k_t]])
        mm = polar * np.array([[2.0, 1.0], [1.0, 2.0]]) + np.diag([0.0, 0.02])
        ref = np.sqrt(scipy.linalg.eigh(kk, mm, eigvals_only=True)) / (2 * np.pi)
        res = fp.modal_analysis(m, 3)
        np.testing.assert_allclose(np.sort(res.frequencies_hz), np.sort([axial, *ref]), rtol=1e-12)
        assert res.n_rigid == 0
    # as a parameter: the release's stiffness is updated like the planar one
    m = torsion_model(release=k_t)
    par = fp.Parameter("release", (1, 1), 0.1 * k_t, 10 * k_t, k_t)
    hz = fp.modal_analysis(m, 3, parameters=(par,), theta=[0.3 * k_t]).frequencies_hz
    np.testing.assert_allclose(hz, fp.modal_analysis(torsion_model(release=0.3 * k_t), 3).frequencies_hz, rtol=1e-12)


def test_releases_act_on_the_global_rotation_their_local_axis_lies_along():
    d = space_dict([(1, 0.0, 0.0, 0.0), (2, 0.0, 0.0, 3.0), (3, 4.0, 0.0, 3.0)],
                   [(1, 2, [1.0, 0.0, 0.0], "test-space-rod", {"releases_j": {"ry": 0.0, "rz": 1e4}}),
                    (2, 3, [0.0, 0.0, 1.0], "test-space-rod", {"releases_i": {"rz": 2e4}})],
                   supports=[(1, ["x", "y", "z"] + ROT)], masses=[{"node": 2, "mass_kg": 1, "inertia_kg_m2": 1e-3},
                                                                  {"node": 3, "mass_kg": 1, "inertia_kg_m2": 1e-3}])
    m = fp.model.model_from_dict(d, "frame.model.json")
    np.testing.assert_allclose(m.local_axes(1), [[0, 0, 1], [0, -1, 0], [1, 0, 0]], atol=1e-15)
    np.testing.assert_allclose(m.local_axes(2), [[1, 0, 0], [0, 1, 0], [0, 0, 1]], atol=1e-15)
    dm = DofMap.of(m)
    # column along z, vecxz x: local ry turns about -y (global ry), local rz about x (global rx)
    assert dm.hinges[(1, 2)].keys() == {"ry", "rx"} and dm.hinges[(2, 2)].keys() == {"rz"}
    assert dm.hinge_stiffness[(1, 2)] == {"ry": 0.0, "rx": 1e4}
    assert dm.element_dofs[0, 6 + 4] == dm.hinges[(1, 2)]["ry"] and dm.element_dofs[1, 5] == dm.hinges[(2, 2)]["rz"]
    assert fp.model.model_from_dict(fp.model.model_to_dict(m), "again") == m


def test_a_release_about_a_skew_axis_is_the_ends_relative_rotation():
    """The rod along (0.8, 0.6, 0), both nodes clamped, its end at node 1 released in torsion
    (local rx, a skew axis): one DOF is left, the end's rotation h about the rod's axis relative
    to the node, with stiffness k_r + G J / L and the rod's torsional mass at that end,
    rho Ip L / 3 (closed form, to 1e-12); `release_rotation` still names no node rotation."""
    length, g = 1.5, STEEL["shear_modulus_pa"]
    k_t = g * SEC["j_m4"] / length
    polar = 7850 * (SEC["iy_m4"] + SEC["iz_m4"]) * length / 6
    k_r = 1e3
    m = torsion_model(release=k_r, skew=True)
    dm = DofMap.of(m)
    assert not dm.hinges and list(dm.relative) == [(1, 1)] and list(dm.relative[(1, 1)]) == ["rx"]
    res = fp.modal_analysis(m, 1)
    np.testing.assert_allclose(res.frequencies_hz, [np.sqrt((k_t + k_r) / (2 * polar)) / (2 * np.pi)], rtol=1e-12)
    with pytest.raises(ValueError, match=r"rod.model.json: element 1: its release in local 'rx' turns about "
                                         r"\[0.8, 0.6, 0.0\], not along a global axis"):
        release_rotation(m, m.element(1), "rx")


# -- measured data and FRFs with the six directions ---------------------------------------

def test_modal_data_json_and_uff_carry_z_and_rotations(tmp_path):
    m = tower(tmp_path)
    dofs = [(10, "z"), (11, "x"), (11, "y"), (12, "z"), (9, "rx")]
    data = fp.synthetic_measurement(m, 5, dofs=dofs, seed=2, model_name="tower.model.json")
    # the rotation of a node of a pin-jointed truss is supported: its measured entry is zero
    assert np.all(data.shapes[-1] == 0.0)
    data = fp.synthetic_measurement(m, 5, dofs=dofs[:-1], seed=2, model_name="tower.model.json")
    path = fp.save_modal_data(data, tmp_path / "tower.modal.json")
    back = fp.load_modal_data(path)
    assert back.dofs == tuple(dofs[:-1]) and json.loads(path.read_text())["dofs"][0] == [10, "z"]
    uff = fp.save_modal_data(data, tmp_path / "tower.uff")
    read = fp.load_modal_data(uff)  # the layout comes from the model the file names
    assert set(read.dofs) == set(dofs[:-1])
    rows = [read.dofs.index(d) for d in data.dofs]
    np.testing.assert_allclose(read.shapes[rows], data.shapes, rtol=1e-5, atol=1e-5 * np.abs(data.shapes).max())
    p = fp.UpdatingProblem(m, back, fp.element_moduli(m, lower=1.5e11, upper=2.5e11), shape_weight=1.0)
    assert p.evaluate(np.full(len(p.parameters), 2e11))[0] < 1e-20
    # the planar reading of the same file refuses the z values, naming dataset and node
    with pytest.raises(fp.DataFileError, match=r"dataset 55 #1 .*node \d+ has a non-zero z value; the model's nodes "
                                                r"have only x, y, rz"):
        read_uff55(uff, layout=fp.load_model("hframe").layout)


def test_a_planar_model_refuses_a_space_direction_in_modal_data(tmp_path):
    d = fp.synthetic_measurement("hframe", 3, seed=1)
    bad = fp.ModalData("hframe", ((5, "z"),) + d.dofs[1:], d.frequencies_hz, d.shapes, {}, "bad.modal.json")
    with pytest.raises(fp.DataFileError, match=r"field 'dofs'\[0\]: unknown direction 'z'; the nodes of model "
                                                r"'hframe' have \['x', 'y', 'rz'\]"):
        bad.check_model(fp.load_model("hframe"))


@pytest.mark.parametrize("suffix", [".uff", ".npz", ".csv"])
def test_frf_files_carry_z_and_are_checked_against_the_layout(tmp_path, suffix):
    m = tower(tmp_path)
    frfs = fp.synthetic_frf(m, band_hz=(5.0, 60.0), resolution_hz=0.5, path=tmp_path / f"tower{suffix}",
                            model_name="tower.model.json")
    assert frfs.reference == (11, "z") and (12, "z") in frfs.coordinates
    back = read_frf(tmp_path / f"tower{suffix}")
    assert back.coordinates == frfs.coordinates and back.reference == (11, "z")
    np.testing.assert_allclose(back.frf, frfs.frf, rtol={".uff": 1e-4, ".csv": 1e-9, ".npz": 0.0}[suffix])
    ident = fp.identify(back, m, n_modes=2)
    true_hz = fp.modal_analysis(m, 2).frequencies_hz
    np.testing.assert_allclose(ident.data.frequencies_hz, true_hz, rtol=2e-3)
    assert ident.data.dofs == frfs.coordinates
    # a planar model has no z: the channel is named
    with pytest.raises(FRFFileError, match=r"direction 'z' is not a DOF of model 'hframe' \(its nodes have x, y, rz\)"):
        fp.identify(back, "hframe")


# -- the CLI ---------------------------------------------------------------------------------

def test_femu_model_summarises_a_space_model(tmp_path, capsys):
    tower(tmp_path)
    path = tmp_path / "tower.model.json"
    assert cli.main(["model", str(path), "--json", "--modes", "4"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert (s["dimension"], s["node_dofs"], s["n_dofs"]) == (3, ["x", "y", "z", "rx", "ry", "rz"], 72)
    assert s["n_free_dofs"] == 24 and s["n_rigid_modes"] == 0
    np.testing.assert_allclose(s["frequencies_hz"], opensees_truss(fp.load_model(path), 4), rtol=1e-8)
    assert cli.main(["model", str(path), "--modes", "2"]) == 0
    out = capsys.readouterr().out
    assert "space frame (3-D): 6 DOFs per node (x, y, z, rx, ry, rz)" in out and "72 DOFs" in out
    bad = json.loads(path.read_text())
    bad["elements"][0]["orientation"] = [0, 0, 1]  # along the first column
    (tmp_path / "bad.model.json").write_text(json.dumps(bad))
    assert cli.main(["model", str(tmp_path / "bad.model.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bad.model.json: element 1: field 'orientation' [0.0, 0.0, 1.0] is parallel" in err[0]


# -- the diagnosis on a space model ----------------------------------------------------------

@pytest.mark.parametrize("effect", ["mass", "stiffness"])
def test_diagnosis_names_a_hidden_effect_in_a_space_model(effect):
    """Candidates over a space model's elements, nodes and three translations: a hidden mass
    (acting in x, y, z) or a weaker bar is named with its place and size. (Joint candidates
    need elements with bending: the space-frame elements' tests.)"""
    m = tower()
    if effect == "mass":
        truth, kind, place = fp.add_mass(m, 11, 6.0), "added_mass", {"node": 11}
    else:
        truth, kind, place = m.with_element_moduli({7: 0.7 * 2e11}), "stiffness_loss", {"element": 7}
    data = fp.synthetic_measurement(truth, 8, freq_noise=0.002, shape_noise=0.02, seed=3, model_name=m.name)
    d = fp.diagnose(m, data, kinds=("stiffness_loss", "added_mass", "boundary_stiffness"))
    assert (d.cause.kind, d.cause.location) == (kind, place)
    if effect == "mass":
        assert d.cause.estimate["mass_kg"] == pytest.approx(6.0, rel=0.1)
    else:
        assert d.cause.estimate["stiffness_loss_pct"] == pytest.approx(30.0, abs=5.0)
    assert any(c.location == {"node": 12, "direction": "z"} for c in d.candidates if c.kind == "boundary_stiffness")


def test_a_space_model_is_drawn_in_isometric_projection(tmp_path, monkeypatch):
    import femu.reports.diagnosis as report

    m = tower()
    at = report.projected(m, m.coordinates)
    c = np.cos(np.pi / 6)
    np.testing.assert_allclose(at, np.column_stack([(m.coordinates[:, 0] - m.coordinates[:, 1]) * c,
                                                    m.coordinates[:, 2] + 0.5 * (m.coordinates[:, 0] + m.coordinates[:, 1])]))
    planar = fp.load_model("hframe")
    np.testing.assert_array_equal(report.projected(planar, planar.coordinates), planar.coordinates)
    # the drawn undeformed frame (scale 0) is the projected element ends, joined straight
    u = fp.modal_analysis(m, 1).shapes[:, 0]
    curves = report.deformed_frame(m, u, 0.0, n_points=3)
    ends = np.array([[at[m.node_position(e.node_i)], at[m.node_position(e.node_j)]] for e in m.elements])
    np.testing.assert_allclose(curves[:, [0, 2]], ends, atol=1e-12)
    truth = fp.add_mass(m, 11, 6.0)
    data = fp.synthetic_measurement(truth, 4, freq_noise=0.002, shape_noise=0.02, seed=3, model_name=m.name)
    diag = fp.diagnose(m, data, kinds=("added_mass",))
    drawn = []
    monkeypatch.setattr(report, "save_figure", lambda fig, path: drawn.append(fig))
    report.plot_shapes(diag, m, diag.extended_model, data, tmp_path / "shapes.png")
    panel = drawn[0].axes[0]
    assert panel.get_ylabel() == "isometric view, z up (m)"
    nodes = next(line for line in panel.get_lines() if line.get_marker() == "o" and len(line.get_xdata()) == 12)
    np.testing.assert_allclose(np.column_stack([nodes.get_xdata(), nodes.get_ydata()]), at)
    monkeypatch.undo()
    written = report.write_report(diag, m, data, tmp_path)
    assert all(p.exists() and p.stat().st_size > 0 for p in written)
