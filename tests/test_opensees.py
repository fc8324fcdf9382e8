"""The FE model against an independent code: OpenSeesPy, on the H-frame and its variants.

Every case is built twice, once by fe_problem and once, element by element, in OpenSees:
Euler-Bernoulli elements as ``elasticBeamColumn ... -mass rho*A -cMass`` (Linear
transformation), Timoshenko elements as ``ElasticTimoshenkoBeam E G A Iz Avy ... -mass rho*A
-cMass`` with G = E / 2(1 + nu) and Avy = kappa A. A released element end is a second node at
the same coordinates, tied to the joint by ``equalDOF`` in x and y and by a ``zeroLength``
element with an Elastic material in direction 3 (the rotational spring). Frequencies must
agree to 1e-8 relative and shapes to MAC > 0.999999 on all 3 x n_nodes nodal DOFs.

How OpenSees is driven, and why:
- ``eigen('-fullGenLapack', n)``: the default Arpack solver cannot return the zero
  eigenvalues of a free-free structure; the full solver can, and they are dropped (|omega^2|
  below 1 (rad/s)^2, i.e. 0.16 Hz; every physical mode here is above 2 Hz) and counted.
- ``constraints('Transformation')`` eliminates the equalDOF-slaved DOFs, so every DOF left has
  mass. It is also what ``eigen`` builds by default when no analysis exists; 'Plain' gives the
  same here (it accepts identity-matrix equalDOF constraints). 'Penalty' and 'Lagrange' do
  not work with '-fullGenLapack': they leave massless DOFs (infinite eigenvalues).
"""


import numpy as np
import openseespy.opensees as ops
import pytest

import fe_problem as fp
from fe_problem.model import DIRECTIONS, Spring, Support

NOMINAL_HZ = [56.287, 127.217, 228.388, 263.523, 452.854, 658.509, 1043.033, 1248.947, 1442.207, 1813.389]
N_MODES = 10
RIGID_CUTOFF = 1.0  # (rad/s)^2: below this an OpenSees eigenvalue is a zero (rigid-body) mode


def opensees_modes(model: fp.FrameModel, n_modes: int):
    """Build `model` in OpenSees; the lowest `n_modes` non-zero modes (Hz, shapes on model.dofs)
    and the number of zero modes OpenSees found below them."""
    ops.wipe()
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    for n in model.nodes:
        ops.node(n.id, n.x, n.y)
    for s in model.supports:
        ops.fix(s.node, *[int(d in s.directions) for d in DIRECTIONS])
    ops.geomTransf("Linear", 1)
    next_node = max(model.node_ids) + 1
    next_element = max(model.element_ids) + 1
    next_material = 1

    def spring(a: int, b: int, stiffness: float, direction: int) -> None:
        nonlocal next_element, next_material
        ops.uniaxialMaterial("Elastic", next_material, stiffness)
        ops.element("zeroLength", next_element, a, b, "-mat", next_material, "-dir", direction)
        next_element += 1
        next_material += 1

    for e in model.elements:
        ends = []
        for node, release in ((e.node_i, e.release_i), (e.node_j, e.release_j)):
            if release is None:
                ends.append(node)
                continue
            joint = model.node(node)
            ops.node(next_node, joint.x, joint.y)
            ops.equalDOF(node, next_node, 1, 2)
            if release > 0:
                spring(node, next_node, release, 3)
            ends.append(next_node)
            next_node += 1
        mat, sec = model.materials[e.material], model.sections[e.section]
        E = model.element_modulus_pa(e.id)
        rho_a = mat.density_kg_m3 * sec.area_m2
        if e.formulation == "euler-bernoulli":
            ops.element("elasticBeamColumn", e.id, *ends, sec.area_m2, E, sec.inertia_m4, 1,
                        "-mass", rho_a, "-cMass")
        else:
            G = E / (2.0 * (1.0 + mat.poisson_ratio))
            ops.element("ElasticTimoshenkoBeam", e.id, *ends, E, G, sec.area_m2, sec.inertia_m4,
                        sec.shear_coefficient * sec.area_m2, 1, "-mass", rho_a, "-cMass")
    for lm in model.masses:
        ops.mass(lm.node, lm.mass_kg, lm.mass_kg, lm.inertia_kg_m2)
    for s in model.springs:
        # A spring from DOF a to ground, or to the same direction at node b: a zeroLength
        # element from node a to an auxiliary node at a's position that is fixed, or that
        # follows node b's DOF through equalDOF (its other DOFs fixed).
        direction = DIRECTIONS.index(s.dof_a[1]) + 1
        at = model.node(s.dof_a[0])
        ops.node(next_node, at.x, at.y)
        if s.dof_b is None:
            ops.fix(next_node, 1, 1, 1)
        else:
            assert s.dof_b[1] == s.dof_a[1], "this OpenSees builder only ties like directions"
            ops.equalDOF(s.dof_b[0], next_node, direction)
            ops.fix(next_node, *[int(i != direction) for i in (1, 2, 3)])
        spring(s.dof_a[0], next_node, s.stiffness, direction)
        next_node += 1
    ops.constraints("Transformation")
    n_ask = n_modes + 4  # room for the zero modes (3 rigid, 1 mechanism at most here)
    lam = np.array(ops.eigen("-fullGenLapack", n_ask))
    keep = np.flatnonzero(np.abs(lam) > RIGID_CUTOFF)[:n_modes]
    n_zero = int(np.sum(np.abs(lam[: keep[0]]) <= RIGID_CUTOFF))
    shapes = np.array([[ops.nodeEigenvector(node, int(k) + 1, DIRECTIONS.index(d) + 1) for k in keep]
                       for node, d in model.dofs])
    ops.wipe()
    return np.sqrt(lam[keep]) / (2.0 * np.pi), shapes, n_zero


def assert_agrees_with_opensees(model: fp.FrameModel, n_rigid: int) -> fp.ModalResult:
    ours = fp.modal_analysis(model, N_MODES)
    f_os, shapes_os, n_zero = opensees_modes(model, N_MODES)
    assert ours.n_rigid == n_zero == n_rigid
    np.testing.assert_allclose(ours.frequencies_hz, f_os, rtol=1e-8, atol=0)
    macs = np.diag(fp.mac(ours.shapes, shapes_os))
    assert macs.min() > 0.999999, macs
    return ours


def _differs_from_nominal(res: fp.ModalResult, at_least: float = 1e-4) -> None:
    """Guards each case against testing the nominal model twice by accident."""
    nominal = fp.modal_analysis("hframe", N_MODES).frequencies_hz
    assert np.max(np.abs(res.frequencies_hz / nominal - 1.0)) > at_least


@pytest.fixture(scope="module")
def hframe():
    return fp.load_model("hframe")


def test_nominal_euler_bernoulli_matches_opensees(hframe):
    assert_agrees_with_opensees(hframe, n_rigid=3)


def test_reference_frequencies_of_hframe_md(hframe):
    """hframe.md's nominal frequencies come from the exact 9.8 x 32.2 mm section,
    A = b h, I = b h^3 / 12; the shipped model file stores exactly that section."""
    b, h = 0.0098, 0.0322
    assert hframe.sections["bar"].area_m2 == pytest.approx(b * h, rel=1e-12)
    assert hframe.sections["bar"].inertia_m4 == pytest.approx(b * h**3 / 12.0, rel=1e-12)
    res = assert_agrees_with_opensees(hframe, n_rigid=3)
    # hframe.md lists three decimals: agreement to half of the last one
    np.testing.assert_allclose(res.frequencies_hz, NOMINAL_HZ, rtol=0, atol=5e-4 + 1e-9)


def test_timoshenko_matches_opensees(hframe):
    model = fp.with_formulation(hframe, "timoshenko")
    res = assert_agrees_with_opensees(model, n_rigid=3)
    nominal = fp.modal_analysis(hframe, N_MODES).frequencies_hz
    # shear deformation and rotary inertia only lower the frequencies, more so for high modes
    assert np.all(res.frequencies_hz < nominal)
    assert (1 - res.frequencies_hz[-1] / nominal[-1]) > (1 - res.frequencies_hz[0] / nominal[0])


def test_lumped_mass_and_rotary_inertia_match_opensees(hframe):
    # a 150 g shaker attachment at the excitation node and a 30 g accelerometer on the right upright
    model = fp.add_mass(fp.add_mass(hframe, 5, 0.15, 6e-5), 10, 0.03, 2e-6)
    _differs_from_nominal(assert_agrees_with_opensees(model, n_rigid=3))


@pytest.mark.parametrize("element, node, stiffness", [(5, 3, 1e5), (8, 8, 3e4), (10, 8, 3e5)])
def test_flexible_joint_matches_opensees(hframe, element, node, stiffness):
    model = fp.release_element_end(hframe, element, node, stiffness)
    _differs_from_nominal(assert_agrees_with_opensees(model, n_rigid=3))


def test_pinned_joint_adds_a_mechanism_in_both_codes(hframe):
    # a pin (k = 0) where the crossbar meets the left upright: the crossbar and the right upright
    # can rotate together about it, a fourth zero mode
    model = fp.release_element_end(hframe, 5, 3, 0.0)
    assert_agrees_with_opensees(model, n_rigid=4)


def test_crack_split_element_matches_opensees(hframe):
    model = fp.split_element(hframe, 4, 0.37, 1e5)
    assert len(model.nodes) == 14 and len(model.elements) == 13
    _differs_from_nominal(assert_agrees_with_opensees(model, n_rigid=3))


def test_timoshenko_with_crack_and_joint_matches_opensees(hframe):
    model = fp.split_element(fp.with_formulation(hframe, "timoshenko"), 3, 0.6, 5e4)
    model = fp.release_element_end(fp.add_mass(model, 12, 0.05, 1e-5), 11, 8, 2e5)
    _differs_from_nominal(assert_agrees_with_opensees(model, n_rigid=3))


def test_supported_frame_with_springs_matches_opensees(hframe):
    # left upright clamped at its foot, right upright pinned, a tie between the upright tops,
    # a rotational spring at the right foot
    model = hframe.replace(
        supports=(Support(1, ("x", "y", "rz")), Support(6, ("x", "y"))),
        springs=(Spring(1, (5, "x"), (10, "x"), 1e5), Spring(2, (6, "rz"), None, 5e4)))
    _differs_from_nominal(assert_agrees_with_opensees(model, n_rigid=0))


def test_suspended_frame_on_springs_matches_opensees(hframe):
    # rubber-band suspension (a few hundred N/m) turns the rigid modes into 2-13 Hz modes
    model = hframe.replace(springs=(
        Spring(1, (5, "x"), None, 400.0), Spring(2, (5, "y"), None, 600.0), Spring(3, (10, "y"), None, 600.0),
        Spring(4, (1, "rz"), None, 200.0), Spring(5, (5, "x"), (10, "x"), 1e5)))
    res = assert_agrees_with_opensees(model, n_rigid=0)
    assert np.all(res.frequencies_hz[:3] < 15.0)
