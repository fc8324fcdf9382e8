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

from test_beam3d import FRAMES, Frame, Prop, mac_diagonal, opensees_modes, opensees_modes_fresh

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


def frame_of(model: fp.FrameModel, releases_allowed: bool = False) -> Frame:
    """The test_beam3d Frame of a loaded 3-D model (for OpenSees)."""
    props = {}
    for e in model.elements:
        mat, sec = model.materials[e.material], model.sections[e.section]
        props[e.id] = Prop(E=model.element_modulus_pa(e.id), G=mat.shear_modulus * model.element_modulus_pa(e.id)
                           / mat.youngs_modulus_pa, rho=mat.density_kg_m3, A=sec.area_m2, Iy=sec.iy_m4,
                           Iz=sec.iz_m4, J=sec.j_m4, kappa=sec.shear_coefficient)
    assert not model.springs and all(m.inertia_kg_m2 == 0 for m in model.masses)
    assert releases_allowed or all(not any(model.end_releases(e)) for e in model.elements)
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


@pytest.mark.parametrize("formulation", ["euler-bernoulli", "timoshenko"])
def test_released_beam_ends_match_opensees(formulation):
    """The shipped frame with its roof beams' ends released: beams along x semi-rigid about
    their strong axis (local ry, 2e7 N m/rad) and pinned about their weak axis (local rz) at
    their second node; beams along y with a torsion release (local rx, 1e5) and a semi-rigid
    weak axis (local rz, 5e6) at their first node. In OpenSees each is a second node tied by
    equalDOF and zeroLength springs in the global rotations those local axes lie along (an x
    beam's local y, z are global y, z; a y beam's local x is global y, its local z global z)."""
    import dataclasses

    model = fp.with_formulation(fp.load_model("frame3d"), formulation)
    coords = {n.id: (n.x, n.y, n.z) for n in model.nodes}
    elements, releases = [], {}
    for e in model.elements:
        a, b = np.array(coords[e.node_i]), np.array(coords[e.node_j])
        if e.section != "beam" or a[2] != 14.0:
            elements.append(e)
        elif b[0] != a[0]:  # along x
            elements.append(dataclasses.replace(e, releases_j=(("ry", 2e7), ("rz", 0.0))))
            releases[(e.id, e.node_j)] = {5: 2e7, 6: 0.0}
        else:  # along y
            elements.append(dataclasses.replace(e, releases_i=(("rx", 1e5), ("rz", 5e6))))
            releases[(e.id, e.node_i)] = {5: 1e5, 6: 5e6}
    released = model.replace(elements=tuple(elements))
    assert len(releases) == 12
    ours = fp.modal_analysis(released, N_MODES)
    f_os, s_os = opensees_modes(frame_of(released, releases_allowed=True), formulation == "timoshenko", N_MODES,
                                releases=releases)
    np.testing.assert_allclose(ours.frequencies_hz, f_os, rtol=1e-8, atol=0)
    assert mac_diagonal(ours.shapes, s_os).min() > 1 - 1e-10
    # the releases matter: the roof's modes move
    nominal = fp.modal_analysis(model, N_MODES).frequencies_hz
    assert np.max(np.abs(ours.frequencies_hz / nominal - 1)) > 1e-3


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


# --- diagnosis of the shipped example from data of an independent reference ------------------

def cut_member(frame: Frame, eid: int, start: float, end: float, inside) -> Frame:
    """`frame` with member `eid` cut at `start` and `end` (fractions of its length from its first
    node; 0 and 1 make no cut) into up to three members, the section of the one between them
    `inside(section)`; the first part keeps the id `eid`, the others are 10,001 and 10,002."""
    nodes, members = dict(frame.nodes), []
    nxt = max(nodes) + 1
    for m in frame.members:
        if m[0] != eid:
            members.append(m)
            continue
        _, i, j, p, v = m
        a, b = np.array(nodes[i]), np.array(nodes[j])
        cuts = [f for f in (start, end) if 0.0 < f < 1.0]
        ends = [i]
        for f in cuts:
            nodes[nxt] = tuple(a + f * (b - a))
            ends.append(nxt)
            nxt += 1
        ends.append(j)
        at = [0.0, *cuts, 1.0]
        for k in range(len(ends) - 1):
            q = inside(p) if start <= at[k] and at[k + 1] <= end else p
            members.append((eid if k == 0 else 10_000 + k, ends[k], ends[k + 1], q, v))
    return Frame(nodes, members, frame.fixed, frame.masses)


def opensees_data(element_id: int | None = None, stretch=(0.0, 1.0 / 3.0), ratio: float = 1.0,
                  mass: tuple[int, float] | None = None, n_modes: int = 8, freq_noise: float = 0.001,
                  shape_noise: float = 0.01, seed: int = 7) -> fp.ModalData:
    """Measured modes of the shipped frame3d with hidden effects, built and solved by OpenSees:
    element `element_id` cut at the ends of `stretch` (fractions of its length from node_i) with
    E and G times `ratio` between them, and `mass` (node, kg) added; the modes at the model's
    measured DOFs with seeded Gaussian noise (frequencies relative, shapes a fraction of each
    mode's largest entry)."""
    import dataclasses

    model = fp.load_model("frame3d")
    frame = frame_of(model)
    if element_id is not None:
        frame = cut_member(frame, element_id, *stretch, lambda p: dataclasses.replace(p, E=p.E * ratio, G=p.G * ratio))
    nodes, members, masses = frame.nodes, frame.members, dict(frame.masses)
    if mass is not None:
        masses[mass[0]] = masses.get(mass[0], 0.0) + mass[1]
    f, shapes = opensees_modes_fresh(Frame(nodes, members, frame.fixed, masses), False, n_modes)  # any process
    return measured(model, list(nodes), f, shapes, seed, freq_noise, shape_noise,
                    meta={"source": "OpenSeesPy", "freq_noise": freq_noise, "shape_noise": shape_noise})


def measured(model: fp.FrameModel, node_ids, f, shapes, seed: int, freq_noise: float, shape_noise: float,
             meta: dict) -> fp.ModalData:
    """Modes solved outside femu (`f`, and `shapes` with 6 rows per node in the order of
    `node_ids`) as measured data of `model`: its measured DOFs, seeded Gaussian noise
    (frequencies relative, shapes a fraction of each mode's largest entry), sorted by frequency.

    Each mode's sign is fixed before the noise is added (its dot product with a fixed random
    vector over the measured rows made positive): a solver's sign is its own choice, and
    OpenSees' differs with the state of the process that calls it; the noise added to a mode of
    the other sign is, relative to the mode, the opposite draw. (The corner-column rz data of
    tests/test_space_zones.py made after a modal analysis of the H-frame had 7 of its 12 modes
    of the other sign: a different 1 % noise draw, the calibrated chi^2 4,906 instead of 4,744
    and the answer "undetermined"; the frequencies differed by 1e-13, which changes nothing.)"""
    rows = [6 * list(node_ids).index(n) + model.layout.position(d) for n, d in model.measured_dofs]
    rng = np.random.default_rng(seed)
    s = shapes[rows]
    s = s * np.where(np.random.default_rng(0).standard_normal(len(rows)) @ s < 0.0, -1.0, 1.0)
    s = s + shape_noise * np.abs(s).max(axis=0) * rng.standard_normal(s.shape)
    f = f * (1.0 + freq_noise * rng.standard_normal(len(f)))
    order = np.argsort(f)
    return fp.ModalData(model.name, model.measured_dofs, f[order], s[:, order], meta=meta)


def test_measured_data_do_not_depend_on_the_solvers_signs():
    """`measured` gives the same data, bit for bit, from modes of either sign (each mode's sign
    a solver's own choice): the noise is drawn relative to a mode of a fixed sign."""
    model = fp.load_model("frame3d")
    ids = [n.id for n in model.nodes]
    rng = np.random.default_rng(5)
    f, shapes = np.sort(rng.uniform(1.0, 20.0, 8)), rng.standard_normal((6 * len(ids), 8))
    signs = np.array([1.0, -1.0, -1.0, 1.0, -1.0, 1.0, 1.0, -1.0])
    one = measured(model, ids, f, shapes, 7, 0.001, 0.01, meta={})
    other = measured(model, ids, f, shapes * signs, 7, 0.001, 0.01, meta={})
    np.testing.assert_array_equal(one.frequencies_hz, other.frequencies_hz)
    np.testing.assert_array_equal(one.shapes, other.shapes)
    assert np.abs(one.shapes).max() > 0.5  # the modes are there


def _diagnose_cli(tmp_path, capsys, data: fp.ModalData) -> dict:
    path = tmp_path / "measured.modal.json"
    fp.save_modal_data(data, path)
    assert main(["diagnose", str(path), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_diagnose_finds_a_mass_added_to_the_space_frame(tmp_path, capsys):
    """1500 kg added at a roof corner (node 45) of the shipped space frame, modes from OpenSees
    with 0.1 % / 1 % noise: `femu diagnose` names the added mass at that node, its estimate's
    95 % interval holding 1500 kg."""
    record = _diagnose_cli(tmp_path, capsys, opensees_data(mass=(45, 1500.0)))
    cause = record["cause"]
    assert cause["kind"] == "added_mass" and cause["location"] == {"node": 45}, cause
    assert record["causes"][0]["kind"] == "added_mass"
    low, high = record["causes"][0]["interval"]["mass_kg"]
    assert low < 1500.0 < high


def test_diagnose_finds_a_weaker_stretch_of_a_column(tmp_path, capsys):
    """A ground-storey column (element 2) with half its modulus over its lowest third, modes
    from OpenSees: `femu diagnose` names a stiffness loss of that column, the uniform loss of
    about the same flexibility (between 25 % and 50 %): E and G halved over the stretch weaken
    both bending planes, torsion and the axial bar, which no one-plane weak zone does
    (tests/test_space_zones.py hides those). A weaker foot is also, nearly, a base on rotational
    springs: when that support class has more evidence, it may be the answer only as not decisive,
    with the column's loss as its runner-up."""
    record = _diagnose_cli(tmp_path, capsys, opensees_data(element_id=2, ratio=0.5))
    cause = record["causes"][0]  # the local search's
    assert cause["kind"] == "stiffness_loss" and cause["location"]["element"] == 2, cause
    assert 25.0 < cause["estimate"]["stiffness_loss_pct"] < 50.0
    answer = record["answer"]
    if (answer["kind"], answer["location"]) != ("stiffness_loss", {"element": 2}):
        assert answer["kind"] == "support_condition" and answer["location"]["node"] == 2, answer
        assert not answer["decisive"] and answer["runner_up"]["label"].startswith("stiffness_loss@element=2"), answer


def test_kernel_axes_are_the_models_local_axes():
    """beam3d.rotation (vectorised, used by the elements) and FrameModel.local_axes (one
    element, used by drawings and releases) give the same axes on every member of the shipped frame."""
    from fe_problem.elements import beam3d

    model = fp.load_model("frame3d")
    xyz = model.coordinates
    i = [model.node_position(e.node_i) for e in model.elements]
    j = [model.node_position(e.node_j) for e in model.elements]
    r = beam3d.rotation(xyz[i], xyz[j], np.array([e.orientation for e in model.elements], dtype=float))
    np.testing.assert_allclose(r, np.array([model.local_axes(e.id) for e in model.elements]), atol=1e-15)


# --- identification from synthetic FRFs of the space frame -----------------------------------

def test_identify_space_frame_from_synthetic_frfs(tmp_path, capsys):
    """A roving-hammer test of the shipped frame with a hidden 1500 kg at a roof corner: FRFs
    (UFF 58) at its 72 measured coordinates, the reference at that corner in y, 1.5-2.5 %
    damping, 1 % noise. `femu identify` finds at least 7 of the truth's 10 lowest modes (a
    single reference leaves one of the close pair at 1.56/1.57 Hz and one of 4.55/4.57 Hz
    unseen), each within 0.2 % of its frequency and at MAC > 0.97 with a distinct truth mode;
    the 72 coordinates keep their x and y directions."""
    truth = fp.add_mass(fp.load_model("frame3d"), 45, 1500.0)
    frf = tmp_path / "roof.uff"
    fp.synthetic_frf(truth, band_hz=(0.5, 5.0), resolution_hz=0.005, damping=(0.015, 0.025), noise=0.01, seed=3,
                     reference=(45, "y"), model_name="frame3d", path=frf)
    assert main(["identify", str(frf), "--out", str(tmp_path / "ident"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["model"] == "frame3d"
    data = fp.load_modal_data(tmp_path / "ident" / "modal-data.json")
    assert data.dofs == truth.measured_dofs and {d for _, d in data.dofs} == {"x", "y"}
    modes = fp.modal_analysis(truth, 10)
    mac = fp.mac(data.shapes, modes.at(data.dofs))
    partner = mac.argmax(axis=1)
    assert data.n_modes >= 7 and len(set(partner)) == data.n_modes
    assert mac.max(axis=1).min() > 0.97, mac.max(axis=1)
    err = data.frequencies_hz / modes.frequencies_hz[partner] - 1
    assert np.abs(err).max() < 2e-3, err


@pytest.mark.parametrize("element_id, ratio, node, kg, seed", [(2, 0.7, 45, 1500.0, 7), (23, 0.6, 37, 1200.0, 11)])
def test_first_round_finds_the_hidden_mass_beside_a_hidden_column_loss(element_id, ratio, node, kg, seed):
    """A roof-corner mass and a column's loss hidden together in the shipped frame (modes from
    OpenSees, 0.1 % / 1 % noise). The nominal frame's close modes (1.575/1.581 Hz; 4.572/4.574 Hz)
    are turned by any asymmetry, so the measured shapes of those modes say little one mode at a
    time; compared as their cluster (residuals.py), the first-order screen ranks the mass's node
    among those it fits (it ranked it 118th of 724 before, from a base pairing that swapped the
    close pair) and the best single cause is the mass: at its node, or spread over a member that
    ends there (the rounds then name the column loss too: the test below)."""
    from fe_problem.diagnosis import core

    model = fp.load_model("frame3d")
    data = opensees_data(element_id=element_id, stretch=(0.0, 1.0), ratio=ratio, mass=(node, kg), seed=seed)
    cal = core.calibrate(model, data, core.DEFAULT_FREQ_NOISE, core.DEFAULT_SHAPE_NOISE)
    found = core.screen_and_fit(cal, None, core.N_FIT)
    labels = [found.candidates[i].label for i in found.order]
    screened = sorted(range(len(found.candidates)), key=lambda i: -found.screened[i][0])
    rank = [found.candidates[i].label for i in screened].index(f"added_mass@node={node}")
    assert rank < core.N_FIT, rank
    best = found.candidates[min(found.fitted, key=lambda i: found.fitted[i].chi2)]
    ends = {e.id for e in model.elements if node in (e.node_i, e.node_j)}
    assert (best.kind, best.location) == ("added_mass", {"node": node}) or \
        (best.kind == "distributed_mass" and best.location["element"] in ends), (best.label, labels[:5])


@pytest.mark.parametrize("element_id, ratio, node, kg, seed", [(2, 0.7, 45, 1500.0, 7), (23, 0.6, 37, 1200.0, 11)])
def test_diagnose_names_a_column_loss_and_a_roof_mass_hidden_together(tmp_path, capsys, element_id, ratio, node, kg,
                                                                       seed):
    """The issue's "done when": a column's loss and a mass at a roof corner hidden together in the
    shipped frame (modes built and solved by OpenSees, 0.1 % / 1 % noise; two placements and
    seeds): `femu diagnose` names exactly these two causes, both identifiable, the loss within 5
    points of its percentage and the mass within 10 % of its kg, each 95 % interval holding the
    truth. A round holding the first cause at its single-cause size ranks the loss far down (the
    mass fitted alone has taken part of its effect); the rounds choose a further cause by its
    joint fit with the earlier ones and start from the runner-up first cause too (joint.py)."""
    data = opensees_data(element_id=element_id, stretch=(0.0, 1.0), ratio=ratio, mass=(node, kg), seed=seed)
    record = _diagnose_cli(tmp_path, capsys, data)
    named = sorted((c["kind"], c["location"]) for c in record["causes"])
    assert named == [("added_mass", {"node": node}), ("stiffness_loss", {"element": element_id})], record["causes"]
    assert all(c["identifiable"] for c in record["causes"])
    mass = next(c for c in record["causes"] if c["kind"] == "added_mass")
    loss = next(c for c in record["causes"] if c["kind"] == "stiffness_loss")
    assert abs(loss["estimate"]["stiffness_loss_pct"] - 100.0 * (1.0 - ratio)) < 5.0, loss["estimate"]
    assert abs(mass["estimate"]["mass_kg"] / kg - 1.0) < 0.1, mass["estimate"]
    low, high = mass["interval"]["mass_kg"]
    assert low < kg < high
    low, high = loss["interval"]["stiffness_loss_pct"]
    assert low < 100.0 * (1.0 - ratio) < high
