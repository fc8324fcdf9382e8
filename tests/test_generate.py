"""Generated models (fe_problem.model.generate): every element split in n parts, regular frames.

Frequencies are checked against closed forms built independently of the FE code: the
Euler-Bernoulli cantilever (beta_1 L = 1.8751) and the sway of a portal frame with a heavy floor
(slope-deflection)."""

import math

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.model import Element, FrameModel, Material, Node, Section, Support
from fe_problem.suite import split_hframe, storey_frame

E, RHO, A, I, L = 2.1e11, 7850.0, 1.0e-2, 1.0e-4, 4.0


def cantilever() -> FrameModel:
    """One element, fixed at node 1."""
    return FrameModel("cantilever", (Node(1, 0.0, 0.0), Node(2, L, 0.0)), {"steel": Material(E, RHO)},
                      {"s": Section(A, I)}, (Element(1, 1, 2, "s", "steel"),),
                      supports=(Support(1, ("x", "y", "rz")),))


def test_split_cantilever_converges_to_euler_bernoulli():
    beta = 1.875104068711961  # first root of cos(x) cosh(x) = -1
    exact = beta ** 2 * math.sqrt(E * I / (RHO * A * L ** 4)) / (2 * math.pi)
    f = fp.modal_analysis(fp.split_elements(cantilever(), 32), 1).frequencies_hz[0]
    assert f == pytest.approx(exact, rel=1e-6)
    coarse = fp.modal_analysis(fp.split_elements(cantilever(), 2), 1).frequencies_hz[0]
    assert abs(coarse - exact) > abs(f - exact)  # the split is what converges it


def test_portal_frame_sway_against_closed_form():
    """Slope-deflection of a fixed-base portal (inextensible members, joints rotating alike):
    k = (24 E I_c / h^3) (a + 6 b) / (4 a + 6 b), a = E I_c / h, b = E I_b / L; the floor mass
    (2 x 1e6 kg) is 3e3 times the members' own, so f = sqrt(k / 2 m) / 2 pi to about 1e-4."""
    floor, h, span, i_beam = 1.0e6, 3.0, 6.0, 2.0e-4
    frame = fp.regular_frame(1, 1, span, h, floor_mass_kg=floor)
    a, b = E * I / h, E * i_beam / span
    k = 24 * E * I / h ** 3 * (a + 6 * b) / (4 * a + 6 * b)
    exact = math.sqrt(k / (2 * floor)) / (2 * math.pi)
    f = fp.modal_analysis(fp.split_elements(frame, 4), 1).frequencies_hz[0]
    assert f == pytest.approx(exact, rel=1e-3)


def test_regular_frame_size_and_connectivity():
    m = fp.regular_frame(3, 4, 5.0, 3.5, base="pinned", floor_mass_kg=100.0)
    assert (len(m.nodes), len(m.elements)) == (4 * 5, 4 * (4 + 3))
    assert m.n_dof == 60 and all(s.directions == ("x", "y") for s in m.supports) and len(m.supports) == 4
    xy = {n.id: (n.x, n.y) for n in m.nodes}
    columns = [e for e in m.elements if e.section == "column"]
    beams = [e for e in m.elements if e.section == "beam"]
    assert len(columns) == 16 and len(beams) == 12
    for e in columns:
        (xi, yi), (xj, yj) = xy[e.node_i], xy[e.node_j]
        assert xi == xj and yj - yi == pytest.approx(3.5)
    for e in beams:
        (xi, yi), (xj, yj) = xy[e.node_i], xy[e.node_j]
        assert yi == yj and xj - xi == pytest.approx(5.0)
    assert len(m.masses) == 16 and len(m.measured_dofs) == 32
    assert m.total_mass_kg() == pytest.approx(1600.0 + RHO * (16 * 1.0e-2 * 3.5 + 12 * 8.0e-3 * 5.0))


def test_split_elements_sizes_and_what_it_keeps():
    base = fp.release_element_end(fp.load_model("hframe"), 5, 3, 1e5)
    m = fp.split_elements(base, 5)
    assert len(m.elements) == 5 * len(base.elements)
    assert len(m.nodes) == len(base.nodes) + 4 * len(base.elements)
    assert m.total_mass_kg() == pytest.approx(base.total_mass_kg(), rel=1e-12)
    assert (m.supports, m.masses, m.measured_dofs) == (base.supports, base.masses, base.measured_dofs)
    degree = {}
    for e in m.elements:
        for n in (e.node_i, e.node_j):
            degree[n] = degree.get(n, 0) + 1
    assert all(degree[n.id] == 2 for n in m.nodes if n.id not in base.node_ids)
    # the released end stays at its node, on the one part that reaches it
    released = [e for e in m.elements if e.release_i is not None or e.release_j is not None]
    assert len(released) == 1 and 3 in (released[0].node_i, released[0].node_j)
    # the same as splitting one element after another (the suite's H-frames depend on it)
    one_by_one = base
    for eid in base.element_ids:
        piece = eid
        for k in range(4):
            one_by_one = fp.split_element(one_by_one, piece, 1.0 / (5 - k))
            piece = max(one_by_one.element_ids)
    assert m == one_by_one


def test_split_elements_keeps_a_crack_in_its_part():
    cracked = fp.crack_element(cantilever(), 1, 0.3, 5e5)
    m = fp.split_elements(cracked, 4)
    holding = [e for e in m.elements if e.crack_position is not None]
    assert len(holding) == 1 and holding[0].crack_position == pytest.approx(0.2)
    assert m.node(holding[0].node_i).x == pytest.approx(1.0)
    f_split = fp.modal_analysis(m, 2).frequencies_hz
    f_ref = fp.modal_analysis(fp.split_elements(fp.split_element(cantilever(), 1, 0.3, 5e5), 8), 2)
    assert f_split[0] < fp.modal_analysis(fp.split_elements(cantilever(), 4), 1).frequencies_hz[0]
    assert f_ref.frequencies_hz[0] == pytest.approx(f_split[0], rel=5e-3)
    with pytest.raises(ValueError, match="boundary between parts"):
        fp.split_elements(fp.crack_element(cantilever(), 1, 0.5, 5e5), 4)


@pytest.mark.parametrize("call, match", [
    (lambda: fp.split_elements(cantilever(), 0), "parts must be a whole number >= 1"),
    (lambda: fp.split_elements(cantilever(), 2.5), "parts must be a whole number >= 1"),
    (lambda: fp.regular_frame(0, 3), "bays must be"),
    (lambda: fp.regular_frame(2, 3, bay_width_m=-1.0), "bay width must be"),
    (lambda: fp.regular_frame(2, 3, base="rollers"), "base must be one of fixed, pinned"),
])
def test_bad_arguments(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_suite_structures_are_the_generators():
    assert split_hframe(4) == fp.split_elements(fp.load_model("hframe"), 4).replace(name="hframe-split4")
    frame = storey_frame(8)
    assert frame.name == "frame8" and len(frame.elements) == 24 and len(frame.masses) == 16
    assert frame.elements == fp.regular_frame(1, 8).elements


def test_large_frame_builds_in_linear_time():
    m = fp.split_elements(fp.regular_frame(10, 50), 3)
    assert (len(m.nodes), m.n_dof) == (2661, 7983)
    assert np.ptp([n.y for n in m.nodes]) == pytest.approx(150.0)


def test_a_split_keeps_a_crack_in_one_part_and_cuts_a_weak_zone_to_its_parts():
    """Splitting moves no physics: the cracked or weak-zoned element split in two equals the
    split model with the crack (zone pieces) put in by hand; `split_element` no longer copies a
    crack into both parts."""
    from fe_problem.diagnosis import zones

    h = fp.load_model("hframe")
    hz = lambda m: fp.modal_analysis(m, 8).frequencies_hz  # noqa: E731
    s2 = fp.split_elements(h, 2)
    second = max(s2.element_ids) - 12 + 7  # the new part of element 7 (ids follow model order)
    assert s2.element(second).node_i == s2.element(7).node_j
    np.testing.assert_allclose(hz(fp.split_elements(fp.crack_element(h, 7, 0.3, 3e4), 2)),
                               hz(fp.crack_element(s2, 7, 0.6, 3e4)), rtol=1e-12)
    by_hand = zones.with_zone(zones.with_zone(s2, 7, 0.8, 1.0, 0.3), second, 0.0, 0.2, 0.3)
    np.testing.assert_allclose(hz(fp.split_elements(zones.with_zone(h, 7, 0.4, 0.6, 0.3), 2)), hz(by_hand),
                               rtol=1e-10)
    one = fp.split_element(fp.crack_element(h, 7, 0.3, 3e4), 7, 0.5)
    assert [(e.crack_position, e.crack_stiffness) for e in one.elements if e.id in (7, max(one.element_ids))] == \
        [(0.6, 3e4), (None, None)]
