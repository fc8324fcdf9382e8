"""screening.changes (the first-order modes' changes of every candidate, the sparse path's
screen) against the formula it replaced, to the bit: the shape change -G_i^T (D_i phi_i) as a
gather of G_i's rows at each term's DOFs, (c, k, n_coord), summed over k by einsum. The same
bits keep the screen's ties (mirror-image candidates, and every candidate that promises no
drop) exactly tied, so the screening order (largest drop first, ties in index order) is the
one the replaced formula gave."""

from __future__ import annotations

import numpy as np

import fe_problem as fp
from fe_problem.diagnosis import screening
from fe_problem.diagnosis.candidates import all_candidates
from fe_problem.diagnosis.core import calibrate
from fe_problem.diagnosis.modelform import model_form_candidates


def gathered_changes(base, terms):
    """The replaced formula: per group of terms touching k DOFs and per mode, G_i gathered at
    the terms' rows (c, k, n_coord) and contracted with D_i phi_i over k."""
    n_coord = base.phi_c.shape[0]
    dlam = np.zeros((len(terms), len(base.modes)))
    dshape = np.zeros((len(terms), n_coord, len(base.modes)))
    for idx in screening._groups(terms).values():
        free = screening._to_free(base.system, np.array([terms[i].dofs for i in idx]))
        dk = np.array([terms[i].dk for i in idx])
        dm = np.array([terms[i].dm for i in idx])
        dm2 = np.array([terms[i].dm2 if terms[i].dm2 is not None else np.zeros_like(terms[i].dk) for i in idx])
        for j, (i, g) in enumerate(zip(base.modes, base.g)):
            lam = base.lam[i]
            u = base.phi_z[free, i]
            r = np.einsum("ckl,cl->ck", dk - lam * dm + lam ** 2 * dm2, u)
            dlam[idx, j] = np.einsum("ck,ck->c", u, r)
            c_i = 0.5 * np.einsum("ck,ckl,cl->c", u, -dm + 2.0 * lam * dm2, u)
            dshape[idx, :, j] = -np.einsum("ckq,ck->cq", g[free], r) + c_i[:, None] * base.phi_c[None, :, i]
    return dlam, dshape


def hframe_calibration():
    h = fp.load_model("hframe")
    data = fp.synthetic_measurement(fp.add_mass(h, 6, 0.2), 8, freq_noise=0.002, shape_noise=0.02, seed=11,
                                    model_name=h.name)
    return calibrate(h, data, 0.002, 0.02)


def test_the_changes_are_the_gathered_formulas_to_the_bit():
    # every candidate with a term on the H-frame: terms of 1, 2, 6, 9 and 12 DOFs, with mass
    # terms of second order (dm2)
    cal = hframe_calibration()
    st = cal.setting
    terms = [c.term() for c in all_candidates(st) + model_form_candidates(st) if c.term is not None]
    assert {len(t.dofs) for t in terms} >= {1, 2, 6, 12} and any(t.dm2 is not None for t in terms)
    base = screening.baseline(fp.AffineModel(st.model), st.coords, st.n_modes)
    dlam, dshape = screening.changes(base, terms)
    ref_lam, ref_shape = gathered_changes(base, terms)
    assert np.abs(ref_shape).max() > 0 and np.abs(ref_lam).max() > 0
    np.testing.assert_array_equal(dlam, ref_lam)
    np.testing.assert_array_equal(dshape, ref_shape)


def test_the_screen_and_its_order_of_ties_are_unchanged(monkeypatch):
    # screen_all with the changes as they are and with the replaced formula: the same (drop, a)
    # of every candidate, so the same order largest drop first with ties in index order
    cal = hframe_calibration()
    st = cal.setting
    cands = all_candidates(st) + model_form_candidates(st)
    now = np.array(screening.screen_all(cal.obs, cal.base, st.model, st.coords, st.n_modes, cands), dtype=float)
    monkeypatch.setattr(screening, "changes", gathered_changes)
    before = np.array(screening.screen_all(cal.obs, cal.base, st.model, st.coords, st.n_modes, cands), dtype=float)
    np.testing.assert_array_equal(now, before)
    drops = now[:, 0][np.isfinite(now[:, 0])]
    assert drops.max() > 10.0 and len(drops) - len(np.unique(drops)) > 10  # ties to order (no drop, at least)
    key = np.where(np.isfinite(now[:, 0]), -now[:, 0], np.inf)
    order = sorted(range(len(cands)), key=lambda i: key[i])
    assert order == list(np.argsort(np.where(np.isfinite(before[:, 0]), -before[:, 0], np.inf), kind="stable"))


def test_a_batch_of_moved_modes_is_each_moved_alone_to_the_bit():
    # screening._moved_batch (the screen's and the pinned moduli's batches) against _moved, one
    # candidate at a time, for paired modes in one run (moved in place) and with gaps
    cal = hframe_calibration()
    st = cal.setting
    terms = [c.term() for c in all_candidates(st) if c.term is not None][:40]
    for modes in (np.arange(8), np.array([0, 2, 3, 6])):
        base = screening.baseline(fp.AffineModel(st.model), st.coords, st.n_modes, modes)
        dlam, dshape = screening.changes(base, terms)
        steps = np.linspace(1e-4, 1e-2, len(terms))
        hz, shapes = screening._moved_batch(base.lam, base.phi_c, modes, dlam, dshape, steps)
        for k in range(len(terms)):
            one_hz, one_shapes = screening._moved(base.lam, base.phi_c, modes, dlam[k], dshape[k], steps[k])
            np.testing.assert_array_equal(hz[k], one_hz)
            np.testing.assert_array_equal(shapes[k], one_shapes)
        assert not np.array_equal(shapes[0], base.phi_c)
