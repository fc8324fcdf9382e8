"""The model-form candidates' first-order terms (diagnosis/local.py: `depth`, `node_move`),
which let a large model's 6,000 model-form candidates be screened from one set of modes
(screening.screen_steps) instead of a model built and solved per candidate.

Checked against an independent route: the model the candidate builds (modelform.member_depth,
moved_node) assembled by `AffineModel` at +-h and differenced; and the first-order screen
against the exact one-step screen (`fit.screen`) on the H-frame with a hidden geometry error."""

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.diagnosis.core import calibrate
from fe_problem.diagnosis.fit import screen
from fe_problem.diagnosis.local import LocalMatrices
from fe_problem.diagnosis.modelform import member_depth, model_form_candidates, moved_node
from fe_problem.diagnosis.screening import screen_all, screen_steps


def _assembled(model):
    system = fp.AffineModel(model, solver="dense")
    return system._solver.k0, system._solver.m0, system


def _embedded(term, system, shape):
    """The term's (dk, dm) as matrices on the free DOFs of `system`."""
    pos = np.full(system.dofmap.n_total, -1)
    pos[system.dofmap.free] = np.arange(system.n_free)
    rows = pos[term.dofs]
    ok = rows >= 0
    k, m = np.zeros(shape), np.zeros(shape)
    k[np.ix_(rows[ok], rows[ok])] = term.dk[np.ix_(ok, ok)]
    m[np.ix_(rows[ok], rows[ok])] = term.dm[np.ix_(ok, ok)]
    return k, m


@pytest.fixture(scope="module")
def frame():
    """A split 2-bay 3-storey frame with a released end (a hinge DOF in an element's DOFs)."""
    m = fp.split_elements(fp.regular_frame(2, 3, floor_mass_kg=500.0), 2)
    return fp.release_element_end(m, 3, m.element(3).node_j, 2e6)


def test_depth_and_node_terms_are_the_assembled_models_derivatives(frame):
    local = LocalMatrices(frame)
    k0, _, system = _assembled(frame)
    h = 1e-4
    checked = 0
    for element in (1, 3, 7):
        for sign in (1.0, -1.0):
            kp, mp, _ = _assembled(member_depth(frame, element, 1.0 + sign * h))
            km, mm, _ = _assembled(member_depth(frame, element, 1.0 - sign * h))
            dk, dm = _embedded(local.depth(element, sign), system, k0.shape)
            np.testing.assert_allclose(dk, (kp - km) / (2 * h), rtol=0, atol=1e-7 * np.abs(dk).max())
            np.testing.assert_allclose(dm, (mp - mm) / (2 * h), rtol=0, atol=1e-7 * np.abs(dm).max())
            checked += 1
    for node in (3, 5, 8):
        for d in "xy":
            for sign in (1.0, -1.0):
                move = (sign * h, 0.0) if d == "x" else (0.0, sign * h)
                kp, mp, _ = _assembled(moved_node(frame, node, *move))
                km, mm, _ = _assembled(moved_node(frame, node, -move[0], -move[1]))
                dk, dm = _embedded(local.node_move(node, d, sign), system, k0.shape)
                assert np.abs(dk).max() > 0
                np.testing.assert_allclose(dk, (kp - km) / (2 * h), rtol=0, atol=1e-7 * np.abs(dk).max())
                np.testing.assert_allclose(dm, (mp - mm) / (2 * h), rtol=0, atol=1e-7 * max(np.abs(dm).max(), 1.0))
                checked += 1
    assert checked == 18


def test_every_plain_member_and_free_node_has_a_term():
    h = fp.load_model("hframe")
    st = calibrate(h, fp.synthetic_measurement(h, 8, seed=1, model_name=h.name), 0.002, 0.02).setting
    forms = model_form_candidates(st)
    assert forms and all(c.term is not None for c in forms)
    cracked = fp.crack_element(h, 2, 0.4, 3e4)
    st_c = calibrate(cracked, fp.synthetic_measurement(cracked, 8, seed=1, model_name=h.name), 0.002, 0.02).setting
    no_term = {c.location.get("element") for c in model_form_candidates(st_c) if c.term is None and
               c.kind == "member_depth"}
    assert no_term == {2}  # a cracked element's matrices are not its geometry's alone: screened by a step


@pytest.mark.parametrize("truth", [lambda m: moved_node(m, 6, 0.0, 0.03), lambda m: member_depth(m, 4, 1.08)],
                         ids=["moved node", "deeper member"])
def test_first_order_model_form_screen_agrees_with_the_step_screen(truth):
    h = fp.load_model("hframe")
    cal = calibrate(h, fp.synthetic_measurement(truth(h), 8, freq_noise=0.002, shape_noise=0.02, seed=1,
                                                model_name=h.name), 0.002, 0.02)
    st = cal.setting
    forms = model_form_candidates(st)
    step = np.array([screen(cal.obs, c, cal.base) for c in forms])
    first = np.array(screen_all(cal.obs, cal.base, st.model, st.coords, st.n_modes, forms))
    assert len(forms) > 20 and step[:, 0].max() > 10.0
    np.testing.assert_allclose(first[:, 0], step[:, 0], atol=0.03 * step[:, 0].max())
    assert [forms[i].label for i in np.argsort(-first[:, 0])[:3]] == [forms[i].label for i in np.argsort(-step[:, 0])[:3]]
    # on the dense path (the H-frame) the diagnosis keeps the exact step screen
    assert screen_steps(cal.obs, cal.base, st, forms) == [tuple(s) for s in step.tolist()]


def one_by_one_and_batched(cal, cands) -> tuple[np.ndarray, np.ndarray]:
    """The first-order screen of `cands` (each with a term) on the calibration `cal`, by
    screening.screen_linear one candidate at a time and by screen_linear_batch all at once."""
    from fe_problem.diagnosis.screening import baseline, changes, screen_linear, screen_linear_batch

    st, base = cal.setting, cal.base
    modes = np.unique(base.pairing[base.pairing >= 0])
    first = baseline(fp.AffineModel(st.model), st.coords, st.n_modes, modes)
    dlam, dshape = changes(first, [c.term() for c in cands])
    one = np.array([screen_linear(cal.obs, base, first.lam, first.phi_c, modes, dlam[i], dshape[i], c.step, c.upper)
                    for i, c in enumerate(cands)])
    batch = screen_linear_batch(cal.obs, base, first.lam, first.phi_c, modes, dlam, dshape,
                                np.array([c.step for c in cands]), np.array([c.upper for c in cands]))
    return one, batch


def test_the_batched_first_order_screen_is_the_one_by_one_screen():
    # screening.screen_linear_batch (every candidate of a chunk at once, the hot path) against
    # screen_linear (one candidate, through Observations.residuals) on every candidate of the H-frame
    from fe_problem.diagnosis.candidates import all_candidates

    h = fp.load_model("hframe")
    truth = fp.add_mass(h, 6, 0.2)
    cal = calibrate(h, fp.synthetic_measurement(truth, 8, freq_noise=0.002, shape_noise=0.02, seed=11,
                                                model_name=h.name), 0.002, 0.02)
    cands = [c for c in all_candidates(cal.setting) + model_form_candidates(cal.setting) if c.term is not None]
    one, batch = one_by_one_and_batched(cal, cands)
    assert len(cands) > 200 and one[:, 0].max() > 10.0 and (one[:, 0] == 0).any()
    np.testing.assert_allclose(batch, one, rtol=1e-9, atol=1e-9 * one[:, 0].max())


def test_the_zone_terms_of_the_grid_in_one_batch_are_each_zones_own():
    # LocalMatrices.zone serves the grid's places from one batch (`_zone_grid`); each must be what
    # zones.zone_stiffness gives for that zone alone
    from fe_problem.diagnosis import zones
    from fe_problem.diagnosis.local import ZONE_STEP

    m = fp.split_elements(fp.regular_frame(2, 3, floor_mass_kg=500.0), 2)
    local = LocalMatrices(m)
    checked = 0
    for e in (1, 4, 9):
        for start, end in zones.zone_places(m, e):
            assert (e, start, end) in local._zone_grid
            pair = zones.zone_stiffness(m, e, start, end, np.array([1.0, 1.0 - ZONE_STEP]))
            np.testing.assert_allclose(local.zone(e, start, end).dk, (pair[1] - pair[0]) / ZONE_STEP, rtol=0,
                                       atol=1e-12 * np.abs(pair[1] - pair[0]).max() / ZONE_STEP)
            checked += 1
    off_grid = zones.zone_place(m, 4, 0.353)
    assert off_grid not in [k[1:] for k in local._zone_grid if k[0] == 4]
    pair = zones.zone_stiffness(m, 4, *off_grid, np.array([1.0, 1.0 - ZONE_STEP]))
    np.testing.assert_array_equal(local.zone(4, *off_grid).dk, (pair[1] - pair[0]) / ZONE_STEP)
    assert checked >= 15
