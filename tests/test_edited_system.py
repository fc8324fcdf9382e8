"""`AffineModel.edited`: a model that differs from a system's own only in some elements'
matrices (a member's depth, the elements at a moved node: the model-form candidates' sizes,
`candidates.solve_model`) built from that system's K and M with those elements' blocks replaced,
on the sparse path. Checked against the full computation it replaces: `AffineModel(model)`
assembled afresh from the model file's edited copy.

Tolerances: K and M are the same sums in another order (the system's values plus new minus old
blocks), so they agree to rounding, 1e-13 of the largest entry; the eigen-solve is the same code
from the same start vector and shift on matrices that differ by that rounding, so the
frequencies agree to 1e-12 relative (measured: 1e-13 at 3,024 DOFs) and the shapes to 1e-10 of
their largest entry (measured: 5e-13; a shape moves by the matrices' change over the gap to the
next mode, well separated on these frames)."""

import dataclasses

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.diagnosis.candidates import Setting, solve, solve_model
from fe_problem.diagnosis.modelform import member_depth, model_form_candidates, moved_node
from fe_problem.model import Support, release_element_end


@pytest.fixture(scope="module")
def frame():
    """A split 2-bay 6-storey frame (sparse path) with one released element end."""
    m = fp.split_elements(fp.regular_frame(2, 6, floor_mass_kg=500.0), 3)
    e = m.element(20)
    return release_element_end(m, 20, e.node_j, 1e6, None)


def _at(model, node):
    return tuple(e.id for e in model.elements if node in (e.node_i, e.node_j))


def _same(system, full, n_modes=8):
    k, m = system.k0.toarray(), system.m0.toarray()
    k_full, m_full = full.k0.toarray(), full.m0.toarray()
    assert np.abs(k - k_full).max() <= 1e-13 * np.abs(k_full).max()
    assert np.abs(m - m_full).max() <= 1e-13 * np.abs(m_full).max()
    assert system.n_rigid == full.n_rigid and system.n_elastic == full.n_elastic
    lam, phi = system.eigen(np.zeros((1, 0)), n_modes, vectors=True)
    lam_full, phi_full = full.eigen(np.zeros((1, 0)), n_modes, vectors=True)
    np.testing.assert_allclose(lam, lam_full, rtol=1e-12, atol=0)
    assert np.abs(phi - phi_full).max() <= 1e-10 * np.abs(phi_full).max()


def test_the_frame_is_on_the_sparse_path(frame):
    system = fp.AffineModel(frame)
    assert system.path == "sparse" and system.n_free > 200 and system.n_rigid == 0


@pytest.mark.parametrize("element, factor", [(20, 0.7), (7, 1.3), (1, 0.5)])
def test_a_member_depth_is_the_full_rebuild(frame, element, factor):
    base = fp.AffineModel(frame)
    model = member_depth(frame, element, factor)
    system = base.edited(model, (element,), x0_modes=8)
    assert system._solver is not base._solver and system.model is model
    _same(system, fp.AffineModel(model, x0_modes=8))


def test_a_moved_node_is_the_full_rebuild(frame):
    """A node moved in x and y: its members turn, filling K and M entries the frame's straight
    members left zero (the pattern grows), and one is the released element."""
    base = fp.AffineModel(frame)
    node = frame.element(20).node_j
    for dx, dy in ((0.05, 0.0), (0.0, -0.08), (0.03, 0.04)):
        model = moved_node(frame, node, dx, dy)
        k = frame.elements.index(frame.element(20))
        assert k in [frame.elements.index(frame.element(e)) for e in _at(frame, node)]
        _same(base.edited(model, _at(frame, node), x0_modes=8), fp.AffineModel(model, x0_modes=8))


def test_what_it_cannot_edit_is_built_afresh(frame):
    """A changed support, a section changed under its own name (every element of it), a moved
    supported node, or an element left out of `element_ids`: the full build (so the same
    modes), not an edit of the system's values."""
    base = fp.AffineModel(frame)
    support = frame.supports[0].node
    free = frame.supports[0].directions[:1]
    name = frame.element(7).section
    thinner = dataclasses.replace(frame.sections[name], inertia_m4=0.8 * frame.sections[name].inertia_m4)
    cases = [(frame.replace(supports=(Support(support, free),) + frame.supports[1:]), ()),
             (frame.replace(sections={**frame.sections, name: thinner}), (7,)),
             (moved_node(frame, support, 0.05, 0.0), _at(frame, support)),
             (moved_node(frame, frame.element(20).node_j, 0.05, 0.0), _at(frame, frame.element(20).node_j)[:1])]
    for model, elements in cases:
        assert base._edit_rows(model, elements) is None
        _same(base.edited(model, elements, x0_modes=8), fp.AffineModel(model, x0_modes=8))


def test_model_form_candidates_solve_the_model_they_extend_to(frame):
    """The model-form candidates' forwards (solve_model from the Setting's system) against each
    size's model (`extend`) assembled afresh."""
    st = Setting(frame, tuple((n, d) for n in frame.node_ids[::3] for d in ("x", "y")), 6)
    forms = model_form_candidates(st, [{"element": 20}])
    kinds = {c.kind for c in forms}
    assert {"member_depth", "node_position"} <= kinds
    for c in forms:
        if c.kind not in ("member_depth", "node_position"):
            continue
        a = c.grid[[3, -1]]
        hz, shapes = c.forward(a)
        for j, v in enumerate(a):
            hz_full, shapes_full = solve(fp.AffineModel(c.extend(float(v)), x0_modes=6), np.zeros((1, 0)),
                                         st.coords, 6)
            np.testing.assert_allclose(hz[j], hz_full[0], rtol=1e-12, atol=0)
            assert np.abs(shapes[j] - shapes_full[0]).max() <= 1e-10 * np.abs(shapes_full).max()
    hz, _ = solve_model(member_depth(frame, 20, 0.9), st, (20,))
    assert np.abs(hz - solve_model(member_depth(frame, 20, 0.9), st)[0]).max() <= 1e-12 * hz.max()
