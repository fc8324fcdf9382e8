"""The reduced form of a joint's flexibility (`reduced.SharedBasis.joint`: the element's local
basis and the released end's relative rotation) against full sparse solves of the candidate's
own system (`Candidate.forward`: the element end released by `release_element_end`, tied by a
rotational spring, the model assembled and solved by ARPACK), and the fit that uses it against
the fit without it.

The planar data hide a crack built differently from every candidate: the element split in two
and joined by a rotational spring (`split_element`); the space frame's, a column end made
flexible in the model file (a release with a spring)."""

import dataclasses

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.assembly import solver_path
from fe_problem.diagnosis.candidates import Setting, all_candidates, joint_flexibility
from fe_problem.diagnosis.core import calibrate
from fe_problem.diagnosis.fit import chi2_batch, fit
from fe_problem.terms import release_axis
from test_reduced_basis import assert_fit_is_the_full_fit, cracked_calibration
from test_space_zones import gable

#: Frequencies of the reduced solve against the full one, relative, over a joint's whole grid
#: (compliance 0 to 50 times the element's E I / L: a rigid joint to a nearly free hinge): the
#: bound `tests/test_reduced_basis.py` holds every local change's grid to (FREQ_RTOL_GRID);
#: measured at most 1.1e-7 over every joint of the planar frame (75, at a = 50: the basis' error
#: at a nearly free joint), 7.3e-8 over the gable's 15 (split in 10, with `STIFF`), 1.4e-13 over
#: the space frame's 132 (each joint's grid solved both ways). The rigid joint (a = 0) is the
#: calibrated model itself, whose modes the basis holds: the two sides differ by the two ARPACK
#: solves (the basis' n_modes + 40 modes and the model's own n_modes, each to ARPACK's
#: tol=1e-10; measured 1.9e-11).
FREQ_RTOL_GRID, FREQ_RTOL_RIGID = 1e-6, 1e-10
#: Stiffer joints than the grid's, checked to FREQ_RTOL_GRID too: the spring's entry grows as
#: 1 / a, which eigh of the stiffness form lost the low modes to (a beam's end on the planar frame
#: was off by 4.3e-6 at a = 1e-6 and 7.7e-4 at 1e-8, while the full model moves 2e-8 to 4e-10
#: from the rigid joint); the flexibility form (`SharedBasis._solve_flexibility`) holds them.
STIFF = (1e-6, 1e-8)
#: Shapes at the measured coordinates, absolute, as a fraction of the largest entry (first order
#: in the basis' error, frequencies second; measured at most 4.2e-5).
SHAPE_ATOL = 1e-4


@pytest.fixture(scope="module")
def planar():
    """The cracked 2 x 8 frame's calibration (test_reduced_basis.cracked_calibration) and its joint
    candidates."""
    cal = cracked_calibration()
    return cal, all_candidates(cal.setting, ("joint_flexibility",))


@pytest.fixture(scope="module")
def space():
    """A 1 x 1 x 3 space frame, each member in two elements (216 DOFs: the sparse path), measured
    with the first column's top end released about its local z and tied by a spring of half its
    E I / L (the model edited, not a candidate): the calibration and its joint candidates."""
    model = fp.split_elements(fp.regular_frame_3d(1, 1, 3, floor_mass_kg=3000.0), 2).replace(name="tower")
    top = {n.id for n in model.nodes if abs(n.z - 3.0) < 1e-9}  # the first floor's nodes
    e = next(el for el in model.elements if el.node_j in top and abs(model.local_axes(el.id)[0][2]) > 0.99)
    ei_l = model.element_modulus_pa(e.id) * model.sections[e.section].inertia_about("rz") / model.element_length_m(e.id)
    truth = model.replace(elements=tuple(dataclasses.replace(el, releases_j=(("rz", 0.5 * ei_l),)) if el is e else el
                                         for el in model.elements))
    data = fp.synthetic_measurement(truth, 8, freq_noise=0.002, shape_noise=0.02, model_name=model.name, seed=2)
    cal = calibrate(model, data, 0.002, 0.02)
    assert solver_path(len(cal.setting.local.dofmap.free)) == "sparse"
    return cal, [c for c in all_candidates(cal.setting, ("joint_flexibility",))]


def _check(c, extra=()):
    """The reduced forward against the full one over the candidate's grid and the sizes `extra`."""
    reduced = c.reduced()
    assert reduced is not None
    a = np.concatenate([np.asarray(c.grid, dtype=float), extra])
    hz_full, sh_full = c.forward(a)
    hz, sh = reduced(a)
    assert hz.shape == hz_full.shape and sh.shape == sh_full.shape
    rigid = a == 0.0
    assert rigid.any() and a.max() == c.upper and np.isin(extra, a).all()
    np.testing.assert_allclose(hz[rigid], hz_full[rigid], rtol=FREQ_RTOL_RIGID, atol=0.0)
    np.testing.assert_allclose(hz, hz_full, rtol=FREQ_RTOL_GRID, atol=0.0)
    # each shape up to its sign: the released model's own vector has the end's rotation as a DOF
    # of its own, which the solvers' sign rule may pick (a space frame's torsion-like modes); the
    # residuals align every shape with the measured one (`Observations.residuals_paired`)
    sh = sh * np.where(np.sum(sh * sh_full, axis=1, keepdims=True) < 0, -1.0, 1.0)
    np.testing.assert_allclose(sh, sh_full, atol=SHAPE_ATOL * np.abs(sh_full).max())


@pytest.mark.parametrize("where", [
    {"node": 14, "element": 20},   # the cracked beam's end
    {"node": 4, "element": 42},    # a beam's end at a column
    {"node": 10, "element": 14},   # a column's end
])
def test_planar_joint_reduced_frequencies_agree_with_full_sparse_solves(planar, where):
    _, cands = planar
    c = next(c for c in cands if c.location == where)
    _check(c, STIFF)


def test_every_planar_joint_has_a_reduced_form(planar):
    """Every joint of a frame with no released end (each end alone in its joint) has one: its
    factory builds a forward (every third joint's, to keep the test short)."""
    _, cands = planar
    assert len(cands) > 50
    assert all(c.reduced() is not None for c in cands[::3])


def test_fine_frame_joint_reduced_frequencies_agree_with_full_sparse_solves():
    """A one-bay two-storey frame, each member in 30 elements (534 DOFs): short stiff elements,
    where the stiffness form's error reached 8.1e-6 at a = 1e-3. Two ends at a column's base node
    and two at a beam-column node, over the grid and `STIFF`."""
    model = fp.split_elements(fp.regular_frame(1, 2, floor_mass_kg=2000.0), 30)
    st = Setting(model, tuple((n.id, d) for n in model.nodes for d in ("x", "y"))[:40], 8)
    assert len(st.local.dofmap.free) == 534 and st.basis is not None
    cands = list(joint_flexibility(st))
    for node in (3, 4):
        for c in [c for c in cands if c.location["node"] == node][:2]:
            _check(c, STIFF)


def test_joint_at_an_element_whose_other_end_is_released():
    """The planar frame's element 20 with its far end (node 66) already released (a spring of
    1e5 N m/rad in the model file): the joint at its near end (node 14) is alone in its joint
    and has a reduced form, on an element whose matrices are the released element's."""
    model = fp.split_elements(fp.regular_frame(2, 8, floor_mass_kg=2000.0), 3)
    assert (model.element(20).node_i, model.element(20).node_j) == (14, 66)
    hinged = model.replace(elements=tuple(dataclasses.replace(e, release_j=1e5) if e.id == 20 else e
                                          for e in model.elements))
    st = Setting(hinged, tuple((n.id, d) for n in hinged.nodes for d in ("x", "y")), 8)
    c = next(c for c in joint_flexibility(st) if c.location == {"node": 14, "element": 20})
    _check(c, STIFF)


def test_skew_axis_joint_reduced_frequencies_agree_with_full_sparse_solves():
    """The gable frame (tests/test_space_zones.py) with each member in 10 elements (234 DOFs):
    the rafters' ends at the eaves and the ridge about their local z, an axis in the x-z plane
    along no global axis (`release_axis`), and their torsion."""
    model = fp.split_elements(gable(), 10)
    st = Setting(model, tuple((n.id, d) for n in model.nodes for d in ("x", "y", "z"))[:60], 8)
    assert st.basis is not None
    skew = [c for c in joint_flexibility(st)
            if release_axis(model, model.element(c.location["element"]), c.location["rotation"]) is not None]
    assert {c.location["rotation"] for c in skew} == {"rz", "rx"} and {c.location["node"] for c in skew} == {3, 4, 5}
    for c in skew:
        _check(c, STIFF)


def test_space_joint_reduced_frequencies_agree_with_full_sparse_solves(space):
    """A space frame's joints about each local axis (two bending planes and the torsion: the
    axis a global unit vector), a column's end and a beam's."""
    _, cands = space
    rotations = {c.location["rotation"] for c in cands}
    assert rotations == {"rx", "ry", "rz"}
    for rotation in sorted(rotations):
        for c in [c for c in cands if c.location["rotation"] == rotation][:2]:
            _check(c)


@pytest.mark.parametrize("where", [{"node": 14, "element": 20}, {"node": 10, "element": 14}])
def test_a_joint_fit_with_the_basis_is_the_full_fit(planar, where):
    """The joint's fit searches on the basis (at most six full solves, `fit._reduced_fit`, where
    the grid has 19 sizes and the search a dozen), its answer is solved with the candidate's own
    system: chi^2 and scale are the full model's at its a. For these two joints (the cracked
    beam's and a column's; not a bound for every joint) a moves from the fit without the basis
    by less than the search's own tolerance (xatol = 1e-4 of the bracket's upper end)."""
    cal, cands = planar
    assert_fit_is_the_full_fit(cal, next(c for c in cands if c.location == where), 6)


def test_a_joint_given_another_joints_basis_gets_the_full_fit(planar):
    """A reduced forward that answers for another joint (a column's end far from the crack) is
    refused by the full solves of `fit._reduced_fit`: the fit is the one without a basis, bit
    for bit."""
    cal, cands = planar
    c = next(c for c in cands if c.location == {"node": 14, "element": 20})
    other = next(c for c in cands if c.location == {"node": 4, "element": 42}).reduced
    grid = np.asarray(c.grid, dtype=float)
    approx = [f.chi2 for f in chi2_batch(cal.obs, c, grid, forward=other())]
    exact = [f.chi2 for f in chi2_batch(cal.obs, c, grid)]
    assert np.argmin(approx) != np.argmin(exact)  # the reduced grid misleads
    full = fit(cal.obs, dataclasses.replace(c, reduced=None))
    got = fit(cal.obs, dataclasses.replace(c, reduced=other))
    assert (got.a, got.s, got.chi2) == (full.a, full.s, full.chi2)


@pytest.mark.parametrize("bias", [1.001, 1.01, 1.05])
def test_a_joint_fit_with_a_reduced_form_biased_in_a_gets_the_full_fit(planar, bias):
    """A reduced forward that answers for a slightly different size (the cracked beam's own, at
    `bias` times a: its minimum lies 0.1-5 % below the full one's, inside the grid's bracket)
    is refused by the full solves of `fit._reduced_fit` (x is no local minimum of the full chi^2
    at x -+ 2 xatol): the fit is the one without a basis, bit for bit. Checking the answer
    against grid[k] alone accepted a = 0.4706 at bias 1.05, where the full fit's is 0.4941."""
    cal, cands = planar
    c = next(c for c in cands if c.location == {"node": 14, "element": 20})

    def biased():
        r = c.reduced()
        return lambda a: r(np.asarray(a, dtype=float) * bias)
    full = fit(cal.obs, dataclasses.replace(c, reduced=None))
    got = fit(cal.obs, dataclasses.replace(c, reduced=biased))
    assert (got.a, got.s, got.chi2) == (full.a, full.s, full.chi2)
