"""The geometry seam (issue 24): the DOF layout, coordinates of the layout's dimension,
per-axis sections, per-rotation releases, the element registry keyed by (name, layout), and
the space frame's model file form (../shared/formats/model-3d.md) read exactly as written.

The space-frame elements themselves are another branch's; the 3-D plumbing is checked here
with a test-only 3-D bar (a truss member: axial stiffness and consistent mass only), which
is trivially right and has closed forms.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.linalg

import fe_problem as fp
from space_elements import SpaceBar
from fe_problem.dofs import PLANAR_FRAME, SPACE_FRAME, DofLayout
from fe_problem.elements import formulation, formulations
from fe_problem.model import Element, FrameModel, Material, ModelFileError, Node, Section, Support, model_to_dict


@pytest.fixture
def space_euler_bernoulli(monkeypatch):
    """The model-3d.md example names no formulation: "euler-bernoulli" of the space frame.
    Where that element is not registered (it is another branch's), the test-only bar stands in
    for it during one test (the registry is restored after it): these tests read files."""
    from fe_problem.elements import base
    key = ("euler-bernoulli", SPACE_FRAME)
    if key not in base._REGISTRY:
        monkeypatch.setitem(base._REGISTRY, key, SpaceBar())

STEEL = {"youngs_modulus_pa": 2.0e11, "shear_modulus_pa": 7.69e10, "density_kg_m3": 7850}
COL = {"area_m2": 1.133e-3, "iy_m4": 1.97e-6, "iz_m4": 0.664e-6, "j_m4": 8.01e-9}
ROT = ["rx", "ry", "rz"]


def space_file(**changes) -> dict:
    """The example of model-3d.md, exactly as outside scripts write it."""
    d = {
        "format": "femu.model/1", "name": "frame3d", "dimension": 3,
        "materials": {"steel": dict(STEEL)}, "sections": {"col": dict(COL)},
        "nodes": [{"id": 1, "x": 0.0, "y": 0.0, "z": 0.0}, {"id": 10, "x": 0.0, "y": 0.0, "z": 0.9}],
        "elements": [{"id": 1, "nodes": [1, 10], "section": "col", "material": "steel", "orientation": [1, 0, 0]}],
        "masses": [{"node": 10, "mass_kg": 88.9}],
        "supports": [{"node": 1, "directions": ["x", "y", "z", "rx", "ry", "rz"]}],
        "measured_dofs": [[10, "x"], [10, "y"]],
    }
    d.update(changes)
    return d


def truss(nodes, pairs, supports=(), masses=(), name="truss") -> FrameModel:
    """A space truss of test-only bars, every node's rotations supported."""
    sup = {n: list(ROT) for n, *_ in nodes}
    for n, dirs in supports:
        sup[n] += list(dirs)
    return fp.model.model_from_dict({
        "format": "femu.model/1", "name": name, "dimension": 3, "materials": {"steel": dict(STEEL)},
        "sections": {"bar": dict(COL)},
        "nodes": [{"id": n, "x": x, "y": y, "z": z} for n, x, y, z in nodes],
        "elements": [{"id": k + 1, "nodes": [i, j], "section": "bar", "material": "steel", "orientation": o,
                      "formulation": "test-space-bar"} for k, (i, j, o) in enumerate(pairs)],
        "masses": [{"node": n, "mass_kg": m} for n, m in masses],
        "supports": [{"node": n, "directions": d} for n, d in sup.items()]}, name)


# -- the layout ---------------------------------------------------------------------------

def test_planar_layout_keeps_its_names_and_rigid_motions():
    assert PLANAR_FRAME.names == ("x", "y", "rz") and PLANAR_FRAME.dimension == 2
    assert PLANAR_FRAME.hinges == ("rz",) and PLANAR_FRAME.rotation == "rz" and PLANAR_FRAME.rotation_position == 2
    xy = np.array([[0.0, 0.0], [2.0, 1.0], [-1.5, 3.0]])
    r = PLANAR_FRAME.rigid_motions(xy).reshape(3, 3, 3)
    np.testing.assert_array_equal(r[:, :, 0], [[1, 0, 0]] * 3)
    np.testing.assert_array_equal(r[:, :, 1], [[0, 1, 0]] * 3)
    np.testing.assert_array_equal(r[:, :, 2], np.column_stack([-xy[:, 1], xy[:, 0], np.ones(3)]))
    assert fp.load_model("hframe").layout is PLANAR_FRAME


def test_space_layout_rigid_motions_are_the_cross_product():
    assert SPACE_FRAME.per_node == 6 and SPACE_FRAME.dimension == 3 and SPACE_FRAME.n_rigid_motions == 6
    with pytest.raises(ValueError, match="use layout.hinges"):
        SPACE_FRAME.rotation
    xyz = np.random.default_rng(0).normal(size=(5, 3))
    r = SPACE_FRAME.rigid_motions(xyz).reshape(5, 6, 6)
    for a in range(3):
        np.testing.assert_array_equal(r[:, :3, a], np.tile(np.eye(3)[a], (5, 1)))
        np.testing.assert_array_equal(r[:, 3:, a], 0.0)
        omega = np.eye(3)[a]
        np.testing.assert_allclose(r[:, :3, 3 + a], np.cross(omega, xyz), atol=0)
        np.testing.assert_array_equal(r[:, 3:, 3 + a], np.tile(omega, (5, 1)))
    with pytest.raises(ValueError, match=r"\(n_nodes, 3\)"):
        SPACE_FRAME.rigid_motions(xyz[:, :2])
    with pytest.raises(ValueError, match="inconsistent"):
        DofLayout(names=("x", "y", "rz"), translations=("x", "y"), hinges=("rx",))


# -- the registry ---------------------------------------------------------------------------

def test_registry_is_keyed_by_name_and_layout():
    assert formulation("euler-bernoulli").layout is PLANAR_FRAME
    assert formulation("euler-bernoulli", PLANAR_FRAME) is formulation("euler-bernoulli")
    assert formulation("test-space-bar", SPACE_FRAME).layout is SPACE_FRAME
    assert "test-space-bar" in formulations(SPACE_FRAME) and "test-space-bar" not in formulations()
    with pytest.raises(KeyError, match="'test-space-bar' for a 2-D model"):
        formulation("test-space-bar")


# -- planar models as before ------------------------------------------------------------------

def test_planar_file_is_written_as_before(tmp_path):
    h = fp.load_model("hframe")
    d = model_to_dict(h)
    assert "dimension" not in d and all(set(n) == {"id", "x", "y"} for n in d["nodes"])
    assert all(set(s) == {"area_m2", "inertia_m4", "shear_coefficient"} for s in d["sections"].values())
    assert all("shear_modulus_pa" not in m for m in d["materials"].values())
    assert all("orientation" not in e and "releases_i" not in e for e in d["elements"])
    assert h.coordinates.shape == (len(h.nodes), 2)
    np.testing.assert_array_equal(h.coordinates, [[n.x, n.y] for n in h.nodes])
    d2 = dict(d, dimension=2)
    assert fp.model.model_from_dict(d2) == fp.model.model_from_dict(d)


@pytest.mark.parametrize("change, message", [
    (lambda d: d.update(dimension=4), r"field 'dimension' must be 2 \(a planar frame\) or 3 \(a space frame\), got 4"),
    (lambda d: d["nodes"][0].update(z=0.5), r"node 1 field 'z': a planar model's nodes lie in the x-y plane"),
    (lambda d: d["sections"]["frame"].update(iy_m4=1e-8),
     r"section 'frame': field 'iy_m4' is not used in a planar model"),
    (lambda d: d["elements"][0].update(orientation=[0, 0, 1]), r"element 1: field 'orientation' is a space model's"),
    (lambda d: d["elements"][0].update(releases_i={"rz": 0}), r"element 1: field 'releases_i' is a space model's"),
])
def test_planar_file_refuses_space_fields(change, message):
    d = model_to_dict(fp.load_model("hframe"))
    d["sections"] = {"frame": next(iter(d["sections"].values()))}
    for e in d["elements"]:
        e["section"] = "frame"
    fp.model.model_from_dict(json.loads(json.dumps(d)))  # valid before the change
    change(d)
    with pytest.raises(ModelFileError, match=message):
        fp.model.model_from_dict(d, "bad.model.json")


# -- the space model's file form ------------------------------------------------------------

def test_space_file_is_read_exactly_as_written(tmp_path, space_euler_bernoulli):
    path = tmp_path / "frame3d.model.json"
    path.write_text(json.dumps(space_file()))
    m = fp.load_model(path)
    assert m.layout is SPACE_FRAME and m.n_dof == 12
    assert m.node(10) == Node(10, 0.0, 0.0, 0.9)
    assert m.materials["steel"].shear_modulus == 7.69e10
    assert m.sections["col"] == Section(1.133e-3, None, 5.0 / 6.0, 1.97e-6, 0.664e-6, 8.01e-9)
    assert m.sections["col"].inertia_about("ry") == 1.97e-6 and m.sections["col"].inertia_about("rx") == 8.01e-9
    assert m.element(1).orientation == (1.0, 0.0, 0.0)
    assert m.coordinates.shape == (2, 3) and m.element_length_m(1) == 0.9
    assert m.dofs[:6] == tuple((1, d) for d in ("x", "y", "z", "rx", "ry", "rz"))
    # vecxz [1, 0, 0] on a column along z: local y = v x local x = -y, local z = x x y = +x (v itself)
    np.testing.assert_allclose(m.local_axes(1), [[0, 0, 1], [0, -1, 0], [1, 0, 0]], atol=1e-15)
    # the default shear modulus is E / 2(1 + nu)
    assert Material(2.0e11, 7850.0, 0.25).shear_modulus == 2.0e11 / 2.5
    again = fp.save_model(m, tmp_path / "again.model.json")
    written = json.loads(again.read_text())
    assert written["dimension"] == 3 and written["nodes"][1] == {"id": 10, "x": 0.0, "y": 0.0, "z": 0.9}
    assert written["sections"]["col"] == dict(COL, shear_coefficient=5.0 / 6.0)
    assert written["materials"]["steel"] == dict(STEEL, poisson_ratio=0.3)
    assert fp.load_model(again) == m


def test_local_axes_follow_the_vecxz_rule():
    """local x from i to j, local y = v x local x normalised, local z = local x x local y."""
    rng = np.random.default_rng(3)
    for _ in range(5):
        a, b, v = rng.normal(size=(3, 3))
        m = truss([(1, *a), (2, *b)], [(1, 2, list(v))])
        ex = (b - a) / np.linalg.norm(b - a)
        ey = np.cross(v, ex) / np.linalg.norm(np.cross(v, ex))
        np.testing.assert_allclose(m.local_axes(1), [ex, ey, np.cross(ex, ey)], atol=1e-14)
        assert abs(np.dot(m.local_axes(1)[2], np.cross(ex, v))) < 1e-12  # v lies in local x-z


@pytest.mark.parametrize("change, message", [
    (lambda d: d["elements"][0].update(orientation=[0, 0, 2.5]),
     r"element 1: field 'orientation' \[0.0, 0.0, 2.5\] is parallel to the element \(nodes 1 -> 10\)"),
    (lambda d: d["elements"][0].pop("orientation"), r"element 1: missing field 'orientation'"),
    (lambda d: d["elements"][0].update(orientation=[1, 0]), r"elements\[0\] field 'orientation': must be a vector of 3"),
    (lambda d: d["sections"]["col"].pop("iy_m4"),
     r"section 'col': missing field 'iy_m4' \(a space \(\"dimension\": 3\) model's section has 'iy_m4', 'iz_m4', 'j_m4'\)"),
    (lambda d: d["sections"]["col"].update(inertia_m4=1e-6), r"section 'col': field 'inertia_m4' is not used in a space"),
    (lambda d: d["sections"]["col"].update(j_m4=-1.0), r"section 'col' 'j_m4': must be a finite number > 0"),
    (lambda d: d["materials"]["steel"].update(shear_modulus_pa=0), r"material 'steel' 'shear_modulus_pa'"),
    (lambda d: d["nodes"][1].pop("z"), r"nodes\[1\]: missing field 'z'"),
    (lambda d: d["supports"][0].update(directions=["x", "u"]),
     r"support at node 1: unknown direction 'u'; use one of \('x', 'y', 'z', 'rx', 'ry', 'rz'\)"),
    (lambda d: d.update(measured_dofs=[[10, "theta"]]), r"measured_dofs\[0\]: unknown direction 'theta'"),
    (lambda d: d["elements"][0].update(release_i=0.0), r"element 1: field 'release_i' is a planar model's"),
    (lambda d: d["elements"][0].update(releases_j={"rw": 0.0}), r"element 1 'releases_j': unknown rotation 'rw'"),
    (lambda d: d["elements"][0].update(releases_j=["ry"]), r"field 'releases_j': must be an object"),
])
def test_bad_space_file_names_file_field_and_problem(tmp_path, change, message, space_euler_bernoulli):
    d = space_file()
    change(d)
    path = tmp_path / "bad3d.model.json"
    path.write_text(json.dumps(d))
    with pytest.raises(ModelFileError, match=message) as err:
        fp.load_model(path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


# -- 3-D plumbing with the test-only bar ---------------------------------------------------

def test_a_free_space_bar_has_the_closed_form_axial_frequency():
    """A free-free bar along a skew line: 5 zero modes (the rotation about its own axis moves
    nothing), one elastic mode, omega^2 = 12 E / (rho L^2) with consistent mass."""
    a, b = np.array([0.3, -0.2, 0.1]), np.array([1.1, 0.5, 0.9])
    m = truss([(1, *a), (2, *b)], [(1, 2, [0, 0, 1])])
    res = fp.modal_analysis(m, 1)
    length = np.linalg.norm(b - a)
    assert res.n_rigid == 5 and res.mechanism is None
    np.testing.assert_allclose(res.frequencies_hz[0], np.sqrt(12 * 2e11 / (7850 * length**2)) / (2 * np.pi), rtol=1e-12)
    u = res.at([(1, "x"), (1, "y"), (1, "z"), (2, "x"), (2, "y"), (2, "z")])[:, 0]
    np.testing.assert_allclose(abs(u[3:] @ (b - a)) / np.linalg.norm(u[3:]) / length, 1.0, rtol=1e-12)


def tetrahedron():
    nodes = [(1, 0.0, 0.0, 0.0), (2, 2.0, 0.0, 0.0), (3, 0.7, 1.8, 0.0), (4, 0.9, 0.6, 1.6)]
    pairs = [(i, j, [1.0, 2.0, 3.0]) for i in range(1, 5) for j in range(i + 1, 5)]
    return truss(nodes, pairs, masses=[(4, 5.0)], name="tetra")


def test_a_free_space_body_has_six_rigid_modes_on_both_paths():
    m = tetrahedron()
    dense = fp.AffineModel(m, fp.element_moduli(m, lower=1e11, upper=3e11), solver="dense")
    sparse = fp.AffineModel(m, fp.element_moduli(m, lower=1e11, upper=3e11), solver="sparse")
    assert dense.n_rigid == sparse.n_rigid == 6 and dense.n_elastic == 6 and dense.mechanism is None
    theta = np.random.default_rng(4).uniform(1e11, 3e11, (3, 6))
    ld, _ = dense.eigen(theta, 6)
    ls, _ = sparse.eigen(theta, 6)
    np.testing.assert_allclose(ls, ld, rtol=1e-10)
    # the reference: K and M of the free translations from scratch (closed-form bar matrices)
    for t in range(3):
        k, mm = np.zeros((12, 12)), np.zeros((12, 12))
        for e, th in zip(m.elements, theta[t]):
            i, j = m.node_position(e.node_i), m.node_position(e.node_j)
            d = m.coordinates[j] - m.coordinates[i]
            length = np.linalg.norm(d)
            u = d / length
            idx = np.r_[3 * i:3 * i + 3, 3 * j:3 * j + 3]
            b = np.r_[-u, u]
            k[np.ix_(idx, idx)] += th * COL["area_m2"] / length * np.outer(b, b)
            mm[np.ix_(idx, idx)] += 7850 * COL["area_m2"] * length / 6 * np.kron([[2, 1], [1, 2]], np.eye(3))
        mm[9:12, 9:12] += 5.0 * np.eye(3)
        ref = scipy.linalg.eigh(k, mm, eigvals_only=True)
        assert np.all(np.abs(ref[:6]) < 1e-6 * ref[6])
        np.testing.assert_allclose(ld[t], ref[6:], rtol=1e-10)


def test_supports_per_direction_remove_rigid_modes():
    m = tetrahedron()
    pinned = m.replace(supports=tuple(Support(s.node, s.directions + (("x", "y", "z") if s.node == 1 else ()))
                                      for s in m.supports))
    assert fp.AffineModel(pinned).n_rigid == 3
    one_more = pinned.replace(supports=tuple(Support(s.node, s.directions + (("z",) if s.node == 2 else ()))
                                             for s in pinned.supports))
    assert fp.AffineModel(one_more).n_rigid == 2


def test_updating_problem_on_a_space_model():
    m = tetrahedron().replace(measured_dofs=((4, "x"), (4, "y"), (4, "z"), (3, "z")))
    pars = fp.element_moduli(m, lower=1.5e11, upper=2.5e11)
    truth = np.linspace(1.6e11, 2.4e11, 6)
    data = fp.synthetic_measurement(m, 6, parameters=pars, theta=truth, seed=1)
    assert {d for _, d in data.dofs} == {"x", "y", "z"}
    p = fp.UpdatingProblem(m, data, pars, weights="unit", shape_weight=1.0)
    f = p.evaluate(np.vstack([truth, [q.initial for q in pars]]))
    assert f[0] < 1e-20 and f[1] > 1e-6
