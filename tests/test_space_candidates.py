"""Diagnosis candidates on space frames (issue 24): the joint candidates in torsion as well as
in both bending planes, each checked by a diagnosis of data from an independent reference
(OpenSeesPy builds and solves the truth; tests/test_beam3d.py `opensees_modes`).
"""

from __future__ import annotations

import collections
import dataclasses
import json

import numpy as np

import fe_problem as fp
from fe_problem.diagnosis.candidates import Setting, _bending_compliance_ref, joint_flexibility

from femu.cli import main
from test_frame3d import frame_of, measured
from test_beam3d import mac_diagonal, opensees_modes

STEEL = {"youngs_modulus_pa": 2.1e11, "shear_modulus_pa": 8.1e10, "density_kg_m3": 7850}


def chs(diameter_m: float, wall_m: float) -> dict:
    """A circular hollow section: J = Iy + Iz (a closed tube twists as stiffly as it bends)."""
    inner = diameter_m - 2 * wall_m
    i = np.pi / 64 * (diameter_m ** 4 - inner ** 4)
    return {"area_m2": np.pi / 4 * (diameter_m ** 2 - inner ** 2), "iy_m4": i, "iz_m4": i, "j_m4": 2 * i,
            "shear_coefficient": 0.5}


def umbrella() -> fp.FrameModel:
    """A tube column (two elements, 4 m) carrying four 2.5 m arms (two elements each) at its top,
    a 300 kg mass at each arm's tip: the structure's twist about the column is held by the
    column's torsion alone (no other path), so a torsionally flexible column head is seen in
    its torsional mode. Measured: x, y, z at every node above the base."""
    nodes = [(1, 0.0, 0.0, 0.0), (2, 0.0, 0.0, 2.0), (3, 0.0, 0.0, 4.0)]
    elements = [(1, 2, "col"), (2, 3, "col")]
    k = 4
    for dx, dy in ((1, 0), (0, 1), (-1, 0), (0, -1)):
        nodes += [(k, 1.25 * dx, 1.25 * dy, 4.0), (k + 1, 2.5 * dx, 2.5 * dy, 4.0)]
        elements += [(3, k, "arm"), (k, k + 1, "arm")]
        k += 2
    d = {"format": "femu.model/1", "name": "umbrella", "dimension": 3, "materials": {"steel": dict(STEEL)},
         "sections": {"col": chs(0.2, 0.008), "arm": chs(0.12, 0.005)},
         "nodes": [{"id": n, "x": x, "y": y, "z": z} for n, x, y, z in nodes],
         "elements": [{"id": j + 1, "nodes": [a, b], "section": s, "material": "steel",
                       "orientation": [1.0, 0.0, 0.0] if s == "col" else [0.0, 0.0, 1.0]}
                      for j, (a, b, s) in enumerate(elements)],
         "masses": [{"node": n, "mass_kg": 300.0} for n in (5, 7, 9, 11)],
         "supports": [{"node": 1, "directions": ["x", "y", "z", "rx", "ry", "rz"]}],
         "measured_dofs": [[n, c] for n, *_ in nodes[1:] for c in ("x", "y", "z")]}
    return fp.model.model_from_dict(d, "umbrella.model.json")


def opensees_released(model: fp.FrameModel, releases: dict, n_modes: int):
    """The lowest `n_modes` modes of `model` with end `releases` ({(element, node): {global
    rotation 4|5|6: N m/rad}}) in OpenSees. The released end's own rotation carries no mass, and
    OpenSees' full generalised solver returns its infinite eigenvalues as a few complex ones
    (NaN frequencies): those are dropped."""
    f, shapes = opensees_modes(frame_of(model), False, n_modes + 6, releases=releases)
    real = np.flatnonzero(np.isfinite(f))
    assert len(real) >= n_modes
    return f[real[:n_modes]], shapes[:, real[:n_modes]]


def opensees_data(model: fp.FrameModel, releases: dict, n_modes: int = 10, seed: int = 5) -> fp.ModalData:
    """Modes of `model` with end `releases` built and solved by OpenSees (`opensees_released`),
    at the model's measured DOFs, 0.1 % / 1 % seeded noise."""
    f, shapes = opensees_released(model, releases, n_modes)
    return measured(model, [n.id for n in model.nodes], f, shapes, seed, 0.001, 0.01, meta={"source": "OpenSeesPy"})


def test_space_joints_are_candidates_in_torsion_and_both_bending_planes():
    """Every joint end of the shipped frame is a candidate in local rx, ry and rz; the torsional
    one's reference stiffness is the element's G J / L (the bending ones' E I / L)."""
    model = fp.load_model("frame3d")
    cands = list(joint_flexibility(Setting(model, model.measured_dofs, 14)))
    counts = collections.Counter(c.location["rotation"] for c in cands)
    assert set(counts) == {"rx", "ry", "rz"} and len(set(counts.values())) == 1, counts
    e = model.elements[0]
    mat, sec = model.materials[e.material], model.sections[e.section]
    length = model.element_length_m(e.id)
    assert _bending_compliance_ref(model, e.id, "rx") == mat.shear_modulus * sec.j_m4 / length
    assert _bending_compliance_ref(model, e.id, "ry") == mat.youngs_modulus_pa * sec.iy_m4 / length


def test_our_released_column_head_matches_opensees():
    """The umbrella with its column's top end tied to the head by a torsion spring (local rx of a
    vertical column: global rz) has OpenSees' frequencies to 1e-8: the truth below is the model
    the candidate builds."""
    model = umbrella()
    k = _bending_compliance_ref(model, 2, "rx") / 4.0
    ours = fp.modal_analysis(fp.release_element_end(model, 2, 3, k, ("rx",)), 10)
    f_os, s_os = opensees_released(model, {(2, 3): {6: k}}, 10)
    np.testing.assert_allclose(ours.frequencies_hz, f_os, rtol=1e-8)
    ids = [n.id for n in model.nodes]
    rows = [6 * ids.index(n) + model.layout.position(d) for n, d in model.measured_dofs]
    single = np.append(np.abs(np.diff(f_os)) > 1e-6 * f_os[1:], True) & np.insert(np.abs(np.diff(f_os)) > 1e-6 * f_os[1:], 0, True)
    assert mac_diagonal(ours.at(model.measured_dofs)[:, single], s_os[rows][:, single]).min() > 1 - 1e-8
    nominal = fp.modal_analysis(model, 10).frequencies_hz
    assert np.max(np.abs(ours.frequencies_hz / nominal - 1)) > 0.05  # the twist mode moves


def test_diagnose_names_a_torsionally_flexible_column_head():
    """The umbrella's column head twisting in its connection (a torsion spring of a quarter of
    the column's G J / L, compliance ratio 4), modes from OpenSees with noise: `femu diagnose`
    names a joint flexibility at the head, of the column's end, in torsion (local rx), its
    compliance ratio's 95 % interval holding 4."""
    model = umbrella()
    k = _bending_compliance_ref(model, 2, "rx") / 4.0
    data = opensees_data(model, {(2, 3): {6: k}})
    d = fp.diagnose(model, data, kinds=("stiffness_loss", "added_mass", "joint_flexibility"))
    assert d.cause.kind == "joint_flexibility", d.cause
    assert d.cause.location == {"node": 3, "element": 2, "rotation": "rx"}, d.cause.location
    low, high = d.causes[0].interval["compliance_ratio"]
    assert low < 4.0 < high, (low, high)


# --- joints at the ends of skew members -----------------------------------------------------------

def _skew_joints(model: fp.FrameModel, n_modes: int = 8):
    """The joint candidates of `model` whose rotation is about a skew local axis (along no
    global axis: a relative rotation in the assembly, terms.py)."""
    from fe_problem.terms import release_axis

    meas = tuple((n.id, d) for n in model.nodes for d in ("x", "y", "z"))
    st = Setting(model, meas, n_modes)
    return st, [c for c in joint_flexibility(st)
                if release_axis(model, model.element(c.location["element"]), c.location["rotation"]) is not None]


def test_skew_member_joints_are_candidates_that_match_opensees():
    """The gable's inclined rafter at the ridge (local rz and rx skew, ry along global y) and the
    braced portal's brace at its top (all three local axes skew) are joint candidates about
    their local axes; each candidate's model at compliance ratio 0.5 (a spring of twice the
    member's E I / L or G J / L) has OpenSees' frequencies to 1e-8, OpenSees building the same
    release its own way (the structure turned so that the member's local axes are global,
    a second node with zeroLength springs: test_space_zones.opensees_turned)."""
    from test_space_zones import braced_portal, gable, opensees_turned

    seen = set()
    for model, n_modes in ((gable(), 8), (braced_portal(), 10)):
        st, skew = _skew_joints(model, n_modes)
        seen |= {(model.name, c.location["element"], c.location["node"], c.location["rotation"]) for c in skew}
        for c in skew:
            loc = c.location
            hz = c.forward(np.array([0.5]))[0][0]
            k = _bending_compliance_ref(model, loc["element"], loc["rotation"]) / 0.5
            f_os, _ = opensees_turned(model, loc["element"], {loc["node"]: {loc["rotation"]: k}}, n_modes)
            np.testing.assert_allclose(hz, f_os, rtol=1e-8, atol=0, err_msg=c.label)
            rigid = c.forward(np.array([0.0]))[0][0]
            assert np.max(np.abs(hz / rigid - 1.0)) > 1e-4, c.label  # the joint matters
    assert {("gable", 3, 5, "rz"), ("gable", 3, 5, "rx"), ("case", 200, 23, "rx"), ("case", 200, 23, "ry"),
            ("case", 200, 23, "rz")} <= seen, seen


def test_a_joint_at_an_end_released_before_matches_opensees():
    """The brace's base end already released about its skew local y and z (a joint found
    before): its torsion joint there, and its top end's joints, are candidates whose models at
    compliance ratio 0.5 have OpenSees' frequencies to 1e-8 (the base's earlier springs kept
    as they are: the candidate at that end is solved as its own model at each size, since a
    `release` parameter would vary them too)."""
    from test_space_zones import _released, braced_portal, opensees_turned

    before = {"ry": 3e4, "rz": 3e4}
    model = _released(braced_portal(), 200, i=tuple(before.items()))
    st, skew = _skew_joints(model, 10)
    brace = [c for c in skew if c.location["element"] == 200]
    assert {(c.location["node"], c.location["rotation"]) for c in brace} == {(1, "rx"), (23, "rx"), (23, "ry"),
                                                                             (23, "rz")}
    for c in brace:
        loc = c.location
        k = _bending_compliance_ref(model, 200, loc["rotation"]) / 0.5
        releases = {1: dict(before)}
        releases.setdefault(loc["node"], {})[loc["rotation"]] = k
        f_os, _ = opensees_turned(model, 200, releases, 10)
        np.testing.assert_allclose(c.forward(np.array([0.5]))[0][0], f_os, rtol=1e-8, atol=0, err_msg=c.label)


def test_skew_joint_first_order_terms_are_the_solved_models_slopes():
    """The first-order term of each skew joint candidate (local.py: the dynamic end moment about
    the skew axis, through DofMap.element_block) gives the eigenvalue slopes at a = 0 that the
    candidate's own solved model shows (a one-sided second-order difference of its eigenvalues
    at a = 0, 1e-5, 2e-5): to 1e-4 of the largest slope. Also with the member's other end
    already released about its skew axes (a relative rotation DOF in the element's block)."""
    from fe_problem.assembly import AffineModel
    from fe_problem.diagnosis.screening import baseline, changes
    from test_space_zones import _released, braced_portal, gable

    braced = braced_portal()
    for model in (gable(), braced, _released(braced, 200, i=(("ry", 3e4), ("rz", 3e4)))):
        st, skew = _skew_joints(model, 8)
        assert skew
        first = baseline(AffineModel(model), st.coords, 8)
        dlam, _ = changes(first, [c.term() for c in skew])
        for c, slope in zip(skew, dlam):
            h = 1e-5
            lam = (2 * np.pi * c.forward(np.array([0.0, h, 2 * h]))[0]) ** 2
            numeric = (-3.0 * lam[0] + 4.0 * lam[1] - lam[2]) / (2.0 * h)  # one-sided, second order
            np.testing.assert_allclose(slope, numeric, rtol=0, atol=1e-4 * np.abs(numeric).max(), err_msg=c.label)


def test_diagnose_names_a_flexible_joint_of_an_inclined_rafter_about_its_skew_axis(tmp_path, capsys):
    """The gable (each member in two elements) with its left rafter tied to the ridge by a
    spring about its local z (out-of-plane bending: an axis in the x-z plane, along no global
    axis) of half the rafter element's E Iz / L (compliance ratio 2), modes built and solved by
    OpenSees (the structure turned so that the rafter's axes are global: a zeroLength spring
    between two nodes), 10 modes at x, y, z of every free node with 0.1 % / 1 % noise: `femu
    diagnose` names that joint (the ridge, the rafter's element, rotation rz),
    decisively, its compliance ratio's 95 % interval holding 2."""
    from fe_problem.terms import release_axis
    from test_space_zones import gable, opensees_turned

    model = fp.split_elements(gable(), 2)
    model = model.replace(measured_dofs=tuple((n.id, d) for n in model.nodes if n.id not in (1, 2)
                                              for d in ("x", "y", "z")))
    rafter = next(e for e in model.elements if e.node_j == 5 and e.section == "raf")
    assert model.coordinates[model.node_position(rafter.node_i)][0] < 5.0  # the left rafter
    assert release_axis(model, rafter, "rz") is not None
    k = _bending_compliance_ref(model, rafter.id, "rz") / 2.0
    f, shapes = opensees_turned(model, rafter.id, {5: {"rz": k}}, 10)
    path = fp.save_model(model, tmp_path / "gable.model.json")
    data = tmp_path / "gable.modal.json"
    modes = measured(model, [n.id for n in model.nodes], f, shapes, 3, 0.001, 0.01, meta={"source": "OpenSeesPy"})
    fp.save_modal_data(dataclasses.replace(modes, model=path.name), data)  # the model file beside it
    assert main(["diagnose", str(data), "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    where = {"node": 5, "element": rafter.id, "rotation": "rz"}
    assert record["cause"]["kind"] == "joint_flexibility" and record["cause"]["location"] == where, record["cause"]
    answer = record["answer"]
    assert (answer["kind"], answer["location"], answer["decisive"]) == ("joint_flexibility", where, True), answer
    low, high = record["causes"][0]["interval"]["compliance_ratio"]
    assert low < 2.0 < high, (low, high)


def test_no_joint_candidate_frees_a_rotation_of_its_node():
    """The gable's ridge with both rafters' ends already released about their skew local z (two
    joints found before): a further joint there may not leave a rotation of the ridge that
    neither rafter holds. Rafter 3 released in torsion too would free every rotation in the
    frame's plane, rafter 4's local z among them (a rotation with no mass: its model could not
    be solved), and likewise rafter 4 in torsion; rafter 3 about its local y (the global y) is
    left, rafter 4's local y being the same axis at this corner. Every candidate's model solves."""
    from test_space_zones import _released, gable

    model = gable()
    released = _released(_released(model, 3, j=(("rz", 1e5),)), 4, i=(("rz", 1e5),))
    st = Setting(released, tuple((n.id, d) for n in model.nodes for d in ("x", "y", "z")), 8)
    cands = list(joint_flexibility(st))
    at_ridge = {(c.location["element"], c.location["rotation"]) for c in cands if c.location["node"] == 5}
    assert at_ridge == {(3, "ry")}, at_ridge
    for c in cands:
        hz = c.forward(np.array([0.5]))[0]
        assert np.isfinite(hz).all() and (hz > 0).all(), c.label
