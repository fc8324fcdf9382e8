"""Model files (femu.model/1), the model transformations, and physics checks of the FE model
against limits and closed-form results."""

import copy
import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.model import Element, FrameModel, Material, Node, Section, Spring, Support, model_to_dict


@pytest.fixture(scope="module")
def hframe():
    return fp.load_model("hframe")


def rich_model(hframe):
    """Every feature of the format at once."""
    m = fp.split_element(fp.with_formulation(hframe, "timoshenko"), 4, 0.37, 5e4)
    m = fp.release_element_end(fp.add_mass(m, 5, 0.15, 6e-5), 8, 8, 2e5)
    m = m.with_element_moduli({3: 6.5e10, 11: 7.2e10})
    return m.replace(name="rich", supports=(Support(6, ("x", "y")),),
                     springs=(Spring(1, (1, "x"), None, 500.0), Spring(2, (5, "x"), (10, "x"), 1e5)),
                     excitation=(10, "y"))


# -- round trip --------------------------------------------------------------------------

def test_save_load_round_trip_is_exact(tmp_path, hframe):
    model = rich_model(hframe)
    path = fp.save_model(model, tmp_path / "rich.json")
    again = fp.load_model(path)
    assert again == model and again.source == str(path)
    a, b = fp.modal_analysis(model, 10), fp.modal_analysis(again, 10)
    np.testing.assert_array_equal(a.frequencies_hz, b.frequencies_hz)
    np.testing.assert_array_equal(a.shapes, b.shapes)
    assert fp.save_model(again, tmp_path / "again.json").read_text() == path.read_text()


def test_shipped_hframe_round_trips(tmp_path, hframe):
    again = fp.load_model(fp.save_model(hframe, tmp_path / "h.json"))
    assert again == hframe
    np.testing.assert_array_equal(fp.modal_analysis(again, 10).frequencies_hz,
                                  fp.modal_analysis(hframe, 10).frequencies_hz)


def test_optional_fields_take_their_defaults(tmp_path):
    minimal = {
        "format": "femu.model/1",
        "materials": {"al": {"youngs_modulus_pa": 7e10, "density_kg_m3": 2700}},
        "sections": {"s": {"area_m2": 3e-4, "inertia_m4": 2.7e-8}},
        "nodes": [{"id": 1, "x": 0, "y": 0}, {"id": 2, "x": 0.5, "y": 0}],
        "elements": [{"id": 1, "nodes": [1, 2], "section": "s", "material": "al"}],
    }
    path = tmp_path / "beam.json"
    path.write_text(json.dumps(minimal))
    m = fp.load_model(path)
    assert m.name == "beam"  # the file's stem
    assert m.elements[0].formulation == "euler-bernoulli" and m.elements[0].release_i is None
    assert m.materials["al"].poisson_ratio == 0.3 and m.sections["s"].shear_coefficient == pytest.approx(5 / 6)
    assert (m.masses, m.springs, m.supports, m.measured_dofs, m.excitation) == ((), (), (), (), None)


def test_the_example_in_the_format_docs_is_a_valid_model(tmp_path):
    doc = (Path(__file__).resolve().parents[1] / "docs" / "model-format.md").read_text()
    example = re.search(r"```json\n(.*?)```", doc, re.S).group(1)
    path = tmp_path / "portal.json"
    path.write_text(example)
    portal = fp.load_model(path)
    assert portal.name == "portal" and portal.element(2).release_j == 5.0e4
    assert portal.element(3).formulation == "timoshenko" and portal.excitation == (3, "x")
    res = fp.modal_analysis(portal, 5)
    assert res.n_rigid == 0 and np.all(np.diff(res.frequencies_hz) > 0) and res.frequencies_hz[0] > 1.0
    # clamped left foot, pinned right foot: zero shape entries there
    assert not np.any(res.at([(1, "x"), (1, "y"), (1, "rz"), (4, "x"), (4, "y")]))


# -- bad model files -----------------------------------------------------------------------

def _set(path, value):
    """A mutation that sets d[path[0]][path[1]]... = value."""
    def change(d):
        for key in path[:-1]:
            d = d[key]
        d[path[-1]] = value
    return change


def _drop(path):
    def change(d):
        for key in path[:-1]:
            d = d[key]
        del d[path[-1]]
    return change


BAD = {
    "missing nodes": (_drop(["nodes"]), ["missing field 'nodes'"]),
    "missing elements": (_drop(["elements"]), ["missing field 'elements'"]),
    "missing materials": (_drop(["materials"]), ["missing field 'materials'"]),
    "missing node x": (_drop(["nodes", 2, "x"]), ["nodes[2]", "missing field 'x'"]),
    "missing element section": (_drop(["elements", 0, "section"]), ["elements[0]", "missing field 'section'"]),
    "missing modulus": (_drop(["materials", "aluminium", "youngs_modulus_pa"]),
                        ["'materials'", "'aluminium'", "youngs_modulus_pa"]),
    "wrong format": (_set(["format"], "femu.model/2"), ["'format'", "femu.model/1"]),
    "unknown node in an element": (_set(["elements", 4, "nodes"], [3, 99]),
                                   ["element 5", "'nodes'", "unknown node 99"]),
    "non-integer node in an element": (_set(["elements", 4, "nodes"], [3, "11"]),
                                       ["elements[4]", "'nodes'", "integer"]),
    "three element ends": (_set(["elements", 4, "nodes"], [3, 11, 12]), ["elements[4]", "'nodes'"]),
    "unknown section": (_set(["elements", 4, "section"], "tube"), ["element 5", "'section'", "'tube'"]),
    "unknown material": (_set(["elements", 4, "material"], "steel"), ["element 5", "'material'", "'steel'"]),
    "zero-length element": (_set(["nodes", 10, "x"], 0.0), ["element 5", "zero length"]),
    "negative modulus": (_set(["materials", "aluminium", "youngs_modulus_pa"], -7e10),
                         ["'aluminium'", "youngs_modulus_pa", "> 0"]),
    "negative element modulus": (_set(["elements", 2, "youngs_modulus_pa"], -7e10),
                                 ["element 3", "youngs_modulus_pa", "> 0"]),
    "zero area": (_set(["sections", "bar", "area_m2"], 0), ["'bar'", "area_m2", "> 0"]),
    "poisson ratio 0.5": (_set(["materials", "aluminium", "poisson_ratio"], 0.5), ["'aluminium'", "poisson_ratio"]),
    "poisson ratio text": (_set(["materials", "aluminium", "poisson_ratio"], "0.33"),
                           ["'aluminium'", "poisson_ratio", "'0.33'"]),
    "node coordinate text": (_set(["nodes", 3, "y"], "0.5"), ["nodes[3]", "'y'", "number"]),
    "fractional node id": (_set(["nodes", 3, "id"], 4.5), ["nodes[3]", "'id'", "integer"]),
    "duplicate node ids": (_set(["nodes", 3, "id"], 3), ["'nodes'", "duplicate", "[3]"]),
    "duplicate element ids": (_set(["elements", 3, "id"], 3), ["'elements'", "duplicate", "[3]"]),
    "unknown formulation": (_set(["elements", 3, "formulation"], "bernoulli"),
                            ["element 4", "'formulation'", "'bernoulli'", "timoshenko"]),
    "negative release": (_set(["elements", 3, "release_i"], -1e4), ["element 4", "release_i"]),
    "measured DOF with unknown direction": (_set(["measured_dofs", 2], [3, "z"]),
                                            ["measured_dofs[2]", "direction 'z'"]),
    "measured DOF at unknown node": (_set(["measured_dofs", 2], [30, "x"]), ["measured_dofs[2]", "unknown node 30"]),
    "measured DOF malformed": (_set(["measured_dofs", 2], "3x"), ["measured_dofs[2]", "[node id, direction]"]),
    "measured DOF twice": (_set(["measured_dofs", 2], [1, "x"]), ["measured_dofs", "twice"]),
    "excitation direction": (_set(["excitation"], [5, "q"]), ["excitation", "'q'"]),
    "support directions not a list": (_set(["supports"], [{"node": 1, "directions": "xy"}]),
                                      ["supports[0]", "'directions'", "list"]),
    "support direction unknown": (_set(["supports"], [{"node": 1, "directions": ["z"]}]), ["node 1", "'z'"]),
    "mass at unknown node": (_set(["masses"], [{"node": 99, "mass_kg": 0.1}]), ["mass", "node 99"]),
    "negative mass": (_set(["masses"], [{"node": 5, "mass_kg": -0.1}]), ["node 5", "mass_kg"]),
    "spring without stiffness": (_set(["springs"], [{"dofs": [[1, "x"]]}]), ["springs[0]", "'stiffness'"]),
    "spring with three DOFs": (_set(["springs"], [{"dofs": [[1, "x"], [2, "x"], [3, "x"]], "stiffness": 1.0}]),
                               ["springs[0]", "'dofs'"]),
    "sections not an object": (_set(["sections"], [1]), ["'sections'", "object"]),
    "weak zone not an object": (_set(["elements", 3, "weak_zone"], [0.2, 0.3, 0.5]), ["elements[3]", "'weak_zone'"]),
    "weak zone without ratio": (_set(["elements", 3, "weak_zone"], {"start": 0.2, "end": 0.3}),
                                ["elements[3]", "'weak_zone'", "modulus_ratio"]),
    "weak zone ratio text": (_set(["elements", 3, "weak_zone"], {"start": 0.2, "end": 0.3, "modulus_ratio": "0.5"}),
                             ["elements[3]", "'weak_zone'", "'modulus_ratio'", "number"]),
    "weak zone reversed": (_set(["elements", 3, "weak_zone"], {"start": 0.4, "end": 0.3, "modulus_ratio": 0.5}),
                           ["element 4", "'weak_zone'", "start < end"]),
    "weak zone outside": (_set(["elements", 3, "weak_zone"], {"start": 0.9, "end": 1.2, "modulus_ratio": 0.5}),
                          ["element 4", "'weak_zone'", "end 1.2"]),
    "weak zone ratio zero": (_set(["elements", 3, "weak_zone"], {"start": 0.2, "end": 0.3, "modulus_ratio": 0.0}),
                             ["element 4", "'modulus_ratio'", "(0, 1]"]),
    "weak zone on a timoshenko element": (
        lambda d: d["elements"][3].update(formulation="timoshenko",
                                          weak_zone={"start": 0.2, "end": 0.3, "modulus_ratio": 0.5}),
        ["element 4", "weak zone", "'euler-bernoulli'"]),
    "nodes not a list": (_set(["nodes"], {"1": [0, 0]}), ["'nodes'", "list"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_model_file(tmp_path, hframe, case):
    change, fragments = BAD[case]
    d = copy.deepcopy(model_to_dict(hframe))
    change(d)
    path = tmp_path / "bad.model.json"
    path.write_text(json.dumps(d))
    with pytest.raises(fp.ModelFileError) as err:
        fp.load_model(path)
    msg = str(err.value)
    assert msg.startswith(str(path)), msg
    for frag in fragments:
        assert frag in msg, msg


def test_bad_json_and_not_an_object(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text('{"format": "femu.model/1", "nodes": [')
    with pytest.raises(fp.ModelFileError, match=r"broken\.json: not valid JSON"):
        fp.load_model(path)
    path.write_text("[1, 2, 3]")
    with pytest.raises(fp.ModelFileError, match=r"broken\.json: expected an object, got list"):
        fp.load_model(path)


def test_unknown_model_name_lists_shipped_models():
    with pytest.raises(FileNotFoundError, match=r"'hframes'.*shipped: .*hframe"):
        fp.load_model("hframes")


# -- transformations -----------------------------------------------------------------------

def _rigid_translation_mass(model, direction):
    """u^T M u for a unit rigid translation: the mass the assembled matrix carries (kg)."""
    system = fp.AffineModel(model)
    u = np.zeros(system.n_free)
    u[system.nodal_rows([(n, direction) for n in model.node_ids])] = 1.0
    return u @ system.m0 @ u


def test_split_element_keeps_total_mass_and_places_the_node(hframe):
    model = fp.split_element(hframe, 4, 0.37, 3e4)
    new = model.node(14)
    assert (new.x, new.y) == pytest.approx((0.0, 0.5235 + 0.37 * 0.1845))
    assert (model.element(4).node_j, model.element(13).node_i, model.element(13).node_j) == (14, 14, 5)
    assert model.element(13).release_i == 3e4 and model.element(4).release_j is None
    assert model.total_mass_kg() == pytest.approx(hframe.total_mass_kg(), rel=1e-14)
    for d in ("x", "y"):
        assert _rigid_translation_mass(model, d) == pytest.approx(hframe.total_mass_kg(), rel=1e-12)
    with pytest.raises(ValueError, match="fraction"):
        fp.split_element(hframe, 4, 1.0)


def _max_rel(a, b):
    return float(np.max(np.abs(a / b - 1.0)))


def test_split_with_stiff_spring_converges_to_the_unsplit_element(hframe):
    rigid = fp.modal_analysis(fp.split_element(hframe, 4, 0.37), 10).frequencies_hz
    unsplit = fp.modal_analysis(hframe, 10).frequencies_hz
    # a rigid split only refines the mesh: the same frame to discretisation error
    assert _max_rel(rigid, unsplit) < 1e-3
    errors = [_max_rel(fp.modal_analysis(fp.split_element(hframe, 4, 0.37, k), 10).frequencies_hz, rigid)
              for k in (1e6, 1e7, 1e8)]
    # a spring in series with the beam: the error falls as 1/k, to 1.5e-5 at 1e8 N m/rad
    assert errors[2] < 3e-5
    for coarse, fine in zip(errors, errors[1:]):
        assert 8.0 < coarse / fine < 12.0
    # and a softer crack only lowers the frequencies
    soft = fp.modal_analysis(fp.split_element(hframe, 4, 0.37, 3e4), 10).frequencies_hz
    assert np.all(soft < rigid)


def _with_zone(model, element, zone):
    return model.replace(elements=tuple(dataclasses.replace(e, weak_zone=zone) if e.id == element else e
                                        for e in model.elements))


def test_weak_zone_round_trips_and_lowers_frequencies(tmp_path, hframe):
    zone = (0.4, 0.5, 0.2)
    model = _with_zone(hframe, 11, zone)
    again = fp.load_model(fp.save_model(model, tmp_path / "zone.model.json"))
    assert again.element(11).weak_zone == zone
    hz = fp.modal_analysis(model, 8).frequencies_hz
    assert np.array_equal(fp.modal_analysis(again, 8).frequencies_hz, hz)
    assert np.all(hz <= fp.modal_analysis(hframe, 8).frequencies_hz * (1 + 1e-12))
    assert _max_rel(hz, fp.modal_analysis(hframe, 8).frequencies_hz) > 0.01
    # the whole element as the zone: its section's inertia times r (axial stiffness and mass kept)
    whole = fp.modal_analysis(_with_zone(hframe, 5, (0.0, 1.0, 0.5)), 8).frequencies_hz
    bar = hframe.sections["bar"]
    thin = hframe.replace(sections={**hframe.sections, "thin": dataclasses.replace(bar, inertia_m4=0.5 * bar.inertia_m4)},
                          elements=tuple(dataclasses.replace(e, section="thin") if e.id == 5 else e
                                         for e in hframe.elements))
    assert _max_rel(whole, fp.modal_analysis(thin, 8).frequencies_hz) < 1e-10


@pytest.mark.parametrize("zone", [(0.4, 0.5, 0.2), (0.0, 0.3, 0.7), (0.7, 1.0, 0.05)])
def test_weak_zone_stiffness_is_the_meshed_beam_condensed(zone):
    """Statics are exact: a beam of 10 Hermite elements, those inside the zone with EI * r,
    condensed to its end DOFs, is the weak-zone element's bending stiffness (to rounding)."""
    from fe_problem.elements import beam2d

    length, inertia, n = 0.3, 2.7e-8, 10
    h = length / n
    k = np.zeros((2 * (n + 1), 2 * (n + 1)))
    for p in range(n):
        r = zone[2] if zone[0] <= (p + 0.5) / n <= zone[1] else 1.0
        kp = beam2d.local_stiffness(np.array([h]), np.array([1.0]), np.array([r * inertia]), np.zeros(1))[0]
        idx = np.arange(2 * p, 2 * p + 4)
        k[np.ix_(idx, idx)] += kp[np.ix_([1, 2, 4, 5], [1, 2, 4, 5])]
    ends, inner = np.array([0, 1, 2 * n, 2 * n + 1]), np.arange(2, 2 * n)
    condensed = k[np.ix_(ends, ends)] - k[np.ix_(ends, inner)] @ np.linalg.solve(k[np.ix_(inner, inner)],
                                                                                 k[np.ix_(inner, ends)])
    one = np.array([1.0])
    extra = beam2d.zone_flexibility(np.array([length]), np.array([inertia]), np.array([zone[0]]),
                                    np.array([zone[1]]), np.array([zone[2]]))
    zoned = beam2d.flexibility_bending_stiffness(np.array([length]), inertia * one, extra)[0]
    assert np.allclose(zoned[np.ix_([1, 2, 4, 5], [1, 2, 4, 5])], condensed, rtol=1e-9, atol=1e-9 * np.abs(condensed).max())


def test_release_with_stiff_spring_converges_to_the_rigid_frame(hframe):
    rigid = fp.modal_analysis(hframe, 10).frequencies_hz
    errors = [_max_rel(fp.modal_analysis(fp.release_element_end(hframe, 5, 3, k), 10).frequencies_hz, rigid)
              for k in (1e6, 1e7, 1e8)]
    assert errors[2] < 1e-4
    for coarse, fine in zip(errors, errors[1:]):
        assert 8.0 < coarse / fine < 12.0
    with pytest.raises(KeyError, match="does not end at node 8"):
        fp.release_element_end(hframe, 5, 8, 1e5)


def _with_kappa(model, kappa):
    sec = dataclasses.replace(model.sections["bar"], shear_coefficient=kappa)
    return fp.with_formulation(model.replace(sections={"bar": sec}), "timoshenko")


def test_timoshenko_with_huge_shear_coefficient_converges_to_euler_bernoulli(hframe):
    eb = fp.AffineModel(hframe)
    scale = np.abs(eb.k0).max()
    # the shear flexibility vanishes as 1/kappa: K_T -> K_EB
    k_err = [np.abs(fp.AffineModel(_with_kappa(hframe, kappa)).k0 - eb.k0).max() / scale for kappa in (1e5, 1e7, 1e9)]
    assert k_err[2] < 1e-10
    assert k_err[0] / k_err[1] == pytest.approx(100.0, rel=1e-3)
    # what stays is the cross-section's rotary inertia in the Timoshenko mass: the remaining
    # frequency gap is its first-order effect, -1/2 phi^T dM phi, to second order
    stiff = _with_kappa(hframe, 1e9)
    d_mass = fp.AffineModel(stiff).m0 - eb.m0
    nominal = fp.modal_analysis(hframe, 10)
    gap = fp.modal_analysis(stiff, 10).frequencies_hz / nominal.frequencies_hz - 1.0
    predicted = -0.5 * np.einsum("im,ij,jm->m", nominal.shapes, d_mass, nominal.shapes)
    assert np.all(np.abs(gap - predicted) < 2.0 * gap**2)
    assert np.all(gap < 0) and np.abs(gap).max() < 0.015
    # and with realistic shear (kappa = 5/6) the frame is softer still
    real = fp.modal_analysis(fp.with_formulation(hframe, "timoshenko"), 10).frequencies_hz
    assert np.all(real / nominal.frequencies_hz - 1.0 < gap)


def test_add_mass_and_with_formulation(hframe):
    heavy = fp.add_mass(hframe, 5, 0.2, 1e-4)
    assert heavy.total_mass_kg() == pytest.approx(hframe.total_mass_kg() + 0.2)
    assert _rigid_translation_mass(heavy, "x") == pytest.approx(hframe.total_mass_kg() + 0.2, rel=1e-12)
    assert np.all(fp.modal_analysis(heavy, 10).frequencies_hz < fp.modal_analysis(hframe, 10).frequencies_hz)
    assert {e.formulation for e in fp.with_formulation(hframe, "timoshenko").elements} == {"timoshenko"}
    with pytest.raises(fp.ModelFileError, match="formulation"):
        fp.with_formulation(hframe, "rayleigh")


# -- an independent physics check: the clamped-free beam ----------------------------------

BETA_L = np.array([1.875104068711961, 4.694091132974175, 7.854757438237613, 10.99554073487547])


def cantilever(n_elements=40, length_m=0.5):
    b, h = 0.0098, 0.0322
    nodes = tuple(Node(i + 1, length_m * i / n_elements, 0.0) for i in range(n_elements + 1))
    elements = tuple(Element(i + 1, i + 1, i + 2, "bar", "al") for i in range(n_elements))
    return FrameModel("cantilever", nodes, {"al": Material(7.0e10, 2700.0, 0.33)},
                      {"bar": Section(b * h, b * h**3 / 12.0)}, elements, supports=(Support(1, ("x", "y", "rz")),))


def test_cantilever_matches_closed_form_frequencies(tmp_path):
    model = fp.load_model(fp.save_model(cantilever(), tmp_path / "cantilever.json"))
    res = fp.modal_analysis(model, 8)
    assert res.n_rigid == 0
    L = 0.5
    mat, sec = model.materials["al"], model.sections["bar"]
    ei, rho_a = mat.youngs_modulus_pa * sec.inertia_m4, mat.density_kg_m3 * sec.area_m2
    bending = BETA_L**2 / (2.0 * np.pi * L**2) * np.sqrt(ei / rho_a)
    axial = np.array([1.0, 3.0]) / (4.0 * L) * np.sqrt(mat.youngs_modulus_pa / mat.density_kg_m3)
    # tell bending from axial modes by their shapes (transverse y vs axial x motion)
    y = np.abs(res.at([(n, "y") for n in model.node_ids])).sum(axis=0)
    x = np.abs(res.at([(n, "x") for n in model.node_ids])).sum(axis=0)
    f_bend, f_axial = res.frequencies_hz[y > x], res.frequencies_hz[x > y]
    # Hermite elements with consistent mass converge as h^4: 40 elements leave < 5e-6
    np.testing.assert_allclose(f_bend[:4], bending, rtol=5e-6)
    # and the consistent-mass bar approaches c / 4L from above, as h^2
    np.testing.assert_allclose(f_axial[:2], axial, rtol=1e-3)
    assert np.all(f_axial[:2] > axial) and np.all(f_bend[:4] > bending)


def test_cantilever_converges_with_mesh():
    coarse = fp.modal_analysis(cantilever(5), 3).frequencies_hz[0]
    fine = fp.modal_analysis(cantilever(10), 3).frequencies_hz[0]
    ei, rho_a = 7e10 * 0.0098 * 0.0322**3 / 12.0, 2700.0 * 0.0098 * 0.0322
    exact = BETA_L[0] ** 2 / (2.0 * np.pi * 0.5**2) * np.sqrt(ei / rho_a)
    e5, e10 = coarse / exact - 1.0, fine / exact - 1.0
    assert 0 < e10 < e5
    assert e5 / e10 == pytest.approx(16.0, rel=0.1)  # fourth-order convergence


def _fresh(model, **changes):
    """`model` with `changes`, built as a new model (every rule checked in full)."""
    fields = {f.name: getattr(model, f.name) for f in dataclasses.fields(model)}
    return FrameModel(**{**fields, **changes})


def _outcome(build):
    try:
        return build()
    except fp.ModelFileError as err:
        return str(err)


def test_a_copy_is_checked_as_a_new_model_is(hframe):
    """`FrameModel.replace` checks an element it keeps only for the section and material it
    names (validate.py's `base`): every copy below, valid or not, comes out as the same model
    built anew does, the same error message included."""
    m = rich_model(hframe)
    sec = m.elements[2].section
    mat = m.elements[2].material
    el = list(m.elements)
    bad_el = dataclasses.replace(el[5], material="unobtainium")
    far = tuple(dataclasses.replace(n, x=n.x + 1e7) if n.id == 3 else n for n in m.nodes)
    same = tuple(dataclasses.replace(n, y=n.y + 0.25) if n.id == 3 else n for n in m.nodes)
    e3 = next(e for e in m.elements if 3 in (e.node_i, e.node_j))
    other = m.node(e3.node_j if e3.node_i == 3 else e3.node_i)
    onto = tuple(dataclasses.replace(n, x=other.x, y=other.y) if n.id == 3 else n for n in m.nodes)
    changes = {
        "a section an element names, gone": dict(sections={k: v for k, v in m.sections.items() if k != sec}),
        "a material an element names, gone": dict(materials={k: v for k, v in m.materials.items() if k != mat}),
        "a section made invalid": dict(sections={**m.sections, sec: dataclasses.replace(m.sections[sec], area_m2=-1.0)}),
        "one new element naming no known material": dict(elements=tuple(el[:5] + [bad_el] + el[6:])),
        "one element's modulus changed (valid)": dict(elements=tuple(el[:5] + [dataclasses.replace(el[5], youngs_modulus_pa=6e10)] + el[6:])),
        "an element's two ends on one node": dict(elements=tuple(el[:1] + [dataclasses.replace(el[1], node_j=el[1].node_i)] + el[2:])),
        "a node moved out of range": dict(nodes=far),
        "a node moved (valid)": dict(nodes=same),
        "an element's id repeated": dict(elements=tuple(el + [el[0]])),
        "a source of its own": dict(source="elsewhere.json", sections={}),
        "a section renamed, its elements kept": dict(sections={("x" + k if k == sec else k): v
                                                               for k, v in m.sections.items()}),
        "a section's shear coefficient changed, its elements kept (valid)": dict(
            sections={**m.sections, sec: dataclasses.replace(m.sections[sec], shear_coefficient=0.5)}),
        "a spring added (valid)": dict(springs=m.springs + (Spring(9, (3, "y"), None, 1e4),)),
        "a spring added at no node": dict(springs=m.springs + (Spring(9, (999, "y"), None, 1e4),)),
        "a mass at no node": dict(masses=m.masses + (dataclasses.replace(m.masses[0], node=999),)),
        "a support at no node": dict(supports=m.supports + (Support(999, ("x",)),)),
        "a measured DOF at no node": dict(measured_dofs=((999, "x"),)),
        "the same tables, a new name (valid)": dict(name="renamed"),
        "a node moved onto its neighbour (an element of zero length)": dict(nodes=onto),
        "a node given another id": dict(nodes=tuple(dataclasses.replace(n, id=99) if n.id == 3 else n for n in m.nodes)),
        "a node moved out of the plane": dict(nodes=tuple(dataclasses.replace(n, z=1.0) if n.id == 3 else n
                                                          for n in m.nodes)),
    }
    outcomes = {name: (_outcome(lambda: m.replace(**ch)), _outcome(lambda: _fresh(m, **ch))) for name, ch in changes.items()}
    for name, (copied, fresh) in outcomes.items():
        assert copied == fresh, name
    errors = [name for name, (copied, _) in outcomes.items() if isinstance(copied, str)]
    assert sorted(errors) == sorted(n for n in changes if "(valid)" not in n)
