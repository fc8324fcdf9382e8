"""The pinned-moduli step of the sparse path (issues 25, 19): the compressed Jacobian has the same
residual norm at every point as the full one; the bounded linear fit is the MAP of the
linearised problem with each modulus' box as a Gaussian prior (checked against independent
solvers and its optimality conditions), unchanged by rounding-sized changes of its data, and on a
1,080-DOF frame with a crack built as a rotational spring it pins the cracked element."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from fe_problem.diagnosis.screening import bounded_linear_fit, compressed


def tall_problem(m: int, n: int, rank: int, seed: int):
    """A residual vector and a rank-deficient Jacobian with decaying columns, as the moduli's."""
    rng = np.random.default_rng(seed)
    jac = rng.normal(size=(m, rank)) @ rng.normal(size=(rank, n)) / np.sqrt(rank) * np.exp(-np.arange(n) / 40)
    return 3.0 * rng.normal(size=m), jac


def test_the_compressed_residuals_have_the_full_norm_everywhere():
    r0, jac = tall_problem(400, 120, 60, 0)
    c, r = compressed(r0, jac)
    assert r.shape == (121, 120)
    np.testing.assert_allclose(r.T @ r, jac.T @ jac, rtol=1e-10, atol=1e-10 * np.abs(jac.T @ jac).max())
    for z in np.random.default_rng(1).uniform(-1, 1, (5, 120)):
        assert abs(np.linalg.norm(c + r @ z) / np.linalg.norm(r0 + jac @ z) - 1) < 1e-12
    small_r0, small_jac = tall_problem(50, 80, 30, 2)  # no more rows than columns: left as it is
    assert compressed(small_r0, small_jac)[1] is small_jac


def test_the_compressed_system_is_the_reduced_qr_of_the_jacobian():
    """`compressed` takes R of [jac, r0] without forming Q; the formula it replaced formed the
    reduced Q of jac: R, Q^T r0 and |r0 - Q Q^T r0|. The two agree row by row up to each row's
    sign (a Householder reflection's), to rounding: 1e-12 of the largest entry (a Jacobian of full
    rank: of a rank-deficient one, Q^T r0 is not unique, and only the norms are, as above)."""
    r0, jac = tall_problem(500, 140, 140, 4)
    c, r = compressed(r0, jac)
    q, r_ref = np.linalg.qr(jac)
    c_ref = q.T @ r0
    sign = np.sign(np.diag(r)[:140]) * np.sign(np.diag(r_ref))
    np.testing.assert_allclose(sign[:, None] * r[:140], r_ref, rtol=0, atol=1e-12 * np.abs(r_ref).max())
    np.testing.assert_array_equal(r[140], 0.0)
    np.testing.assert_allclose(sign * c[:140], c_ref, rtol=0, atol=1e-12 * np.abs(c_ref).max())
    assert abs(abs(c[140]) - np.linalg.norm(r0 - q @ c_ref)) < 1e-12 * np.linalg.norm(r0)


def objective(r0, jac):
    """The MAP objective written out from its definition (chi^2 plus the box priors, sd 1/2 in
    z) and its gradient, on the full (uncompressed) Jacobian."""
    def f(z):
        r = r0 + jac @ (z - 0.5)
        return r @ r + np.sum((2 * (z - 0.5)) ** 2), 2 * jac.T @ r + 8 * (z - 0.5)
    return f


def projected_gradient(f, z):
    """The objective's gradient at z with the components that push into an active bound zeroed.
    For an objective whose Hessian is at least mu I on a box, |z - z*| <= 2 |pg(z)| / mu (from
    f(z*) <= f(z) and strong convexity): with mu = 8 here, a bound on the distance from the
    true optimum that needs no reference solution."""
    g = f(z)[1]
    return np.where(z <= 0, np.minimum(g, 0), np.where(z >= 1, np.maximum(g, 0), g))


def test_the_bounded_fit_is_the_map_by_independent_solvers():
    """The fit (bvls on the compressed system) satisfies the optimality (KKT) conditions of the
    objective written out on the full Jacobian, which puts it within |pg| / 4 of the optimum;
    L-BFGS-B, run on that objective until it makes no progress, agrees within the sum of both
    answers' bounds."""
    r0, jac = tall_problem(600, 150, 80, 3)
    z = bounded_linear_fit(r0, jac)
    f = objective(r0, jac)
    g0 = np.abs(f(np.full(150, 0.5))[1]).max()
    at_lo, at_hi = z <= 0, z >= 1
    assert at_lo.sum() >= 3 and at_hi.sum() >= 3 and (~(at_lo | at_hi)).sum() >= 100  # both bounds, free
    assert np.all((z >= 0) & (z <= 1))
    g = f(z)[1]
    assert np.all(g[at_lo] > 0) and np.all(g[at_hi] < 0)  # each pinned modulus pushed into its bound
    own = np.linalg.norm(projected_gradient(f, z)) / 4
    assert own < 1e-11 * g0  # stationary where free: within 1e-11 x the start's gradient of z*
    other = minimize(f, np.full(150, 0.5), jac=True, method="L-BFGS-B", bounds=[(0.0, 1.0)] * 150,
                     options=dict(ftol=0.0, gtol=0.0, maxiter=20000, maxcor=50)).x
    np.testing.assert_allclose(z, other, rtol=0, atol=own + np.linalg.norm(projected_gradient(f, other)) / 4)
    assert f(z)[0] <= f(other)[0] * (1 + 1e-14)


def replaced_fit(r0, jac):
    """The route `bounded_linear_fit` took before its back substitution: the data rows alone
    compressed, the prior's rows stacked under them, `lsq_linear`'s bvls on the whole."""
    from scipy.optimize import lsq_linear

    n = jac.shape[1]
    c, r = compressed(r0, jac)
    res = lsq_linear(np.vstack([r, 2.0 * np.eye(n)]), np.concatenate([0.5 * r.sum(axis=1) - c, np.ones(n)]),
                     bounds=(0.0, 1.0), method="bvls", max_iter=10 * n + 100)
    z = res.x.copy()
    z[res.active_mask < 0], z[res.active_mask > 0] = 0.0, 1.0
    return z


@pytest.mark.parametrize("misfit", [0.3, 3.0])
def test_the_back_substitution_is_the_replaced_fit(misfit):
    """Inside the box (a small misfit: no modulus at a bound) the answer is the back substitution
    on the compressed data and prior rows; with a large misfit (moduli at both bounds) it is bvls's
    on that compressed system. Both are the replaced route's answer, to 1e-12 in z (the stacked rows'
    condition number is 16 here: rounding), with the same moduli at their bounds."""
    r0, jac = tall_problem(600, 150, 80, 5)
    z, ref = bounded_linear_fit(misfit * r0, jac), replaced_fit(misfit * r0, jac)
    at_bound = (ref <= 0) | (ref >= 1)
    assert (at_bound.sum() == 0) if misfit < 1 else (at_bound.sum() >= 6)
    np.testing.assert_array_equal((z <= 0) | (z >= 1), at_bound)
    np.testing.assert_allclose(z, ref, rtol=0, atol=1e-12)


def test_a_pinned_modulus_is_exactly_on_its_bound():
    """On this problem bvls's last step left two moduli at 1.7e-16 and 1.1e-16, pushed into their
    bound by gradients of 784 and 16,577: counted as free, they broke the optimality conditions.
    The fit sets the moduli of bvls's active set exactly on their bounds."""
    rng = np.random.default_rng(1)
    jac, r0 = rng.standard_normal((600, 150)), 300.0 * rng.standard_normal(600)
    z = bounded_linear_fit(r0, jac)
    f = objective(r0, jac)
    g0 = np.abs(f(np.full(150, 0.5))[1]).max()
    assert ((z <= 0) | (z >= 1)).sum() >= 2
    assert np.linalg.norm(projected_gradient(f, z)) / 4 < 1e-11 * g0


@pytest.fixture(scope="module")
def cracked():
    """The 1,080-DOF benchmark frame (3 bays, 20 storeys, members in three elements) with a
    crack at the middle of element 40 built as a rotational spring (`fp.split_element`, half the
    element's E I / L), calibrated; its pinned moduli and the fit's data (r0, jac)."""
    import sys
    from pathlib import Path

    from fe_problem.diagnosis import screening
    from fe_problem.diagnosis.core import calibrate, residuals_of
    from fe_problem.assembly import solver_path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from test_bench_diagnosis_scale import cracked_frame

    model, data = cracked_frame(3, 20, "cracked")
    cal = calibrate(model, data, 0.002, 0.02)
    assert solver_path(len(cal.setting.local.dofmap.free), "auto", len(model.element_ids)) == "sparse"
    seen = {}
    real = screening.bounded_linear_fit
    screening.bounded_linear_fit = lambda r0, jac: seen.update(r0=r0, jac=jac, z=real(r0, jac)) or seen["z"]
    try:
        pinned = residuals_of(cal).pinned_parameters
    finally:
        screening.bounded_linear_fit = real
    return cal, pinned, seen


def test_the_pinned_moduli_do_not_depend_on_rounding(cracked):
    """Relative changes of 1e-12 in the Jacobian (four random draws) move no modulus by more than
    1e-9 in z and pin no other: the unregularised fit this replaced moved z by 0.3 and changed
    most of its 37 pinned moduli under changes of 1e-15."""
    _, _, seen = cracked
    r0, jac, z = seen["r0"], seen["jac"], seen["z"]
    pins = (z <= 0.005) | (z >= 0.995)
    for seed in range(4):
        wobble = 1 + 1e-12 * np.random.default_rng(seed).standard_normal(jac.shape)
        zp = bounded_linear_fit(r0, jac * wobble)
        assert np.abs(zp - z).max() < 1e-9
        np.testing.assert_array_equal((zp <= 0.005) | (zp >= 0.995), pins)


def test_the_cracked_element_is_the_one_pinned(cracked):
    """The crack softens element 40 well beyond the 1/7 box: it is pinned at the lower bound, it
    moves most, and no other modulus is pinned."""
    cal, pinned, seen = cracked
    assert [(p.element, p.bound) for p in pinned] == [(40, "lower")]
    ids = list(cal.setting.model.element_ids)
    assert ids[int(np.argmax(np.abs(seen["z"] - 0.5)))] == 40


def test_the_jacobian_is_one_model_at_a_time_to_the_bit(monkeypatch):
    """`linear_bounded_moduli` takes its Jacobian's columns from batches of models through the
    batched residuals; each column must be what one model at a time through
    `Observations.residuals` gives, to the bit (the batches are a way of computing the same
    columns, not an approximation of them)."""
    import fe_problem as fp
    from fe_problem.assembly import AffineModel
    from fe_problem.diagnosis import screening
    from fe_problem.diagnosis.core import calibrate
    from fe_problem.modal import frequencies_hz

    h = fp.load_model("hframe")
    truth = h.with_element_moduli({7: 0.7 * h.element_modulus_pa(7)})  # the model file's element 7 softened
    data = fp.synthetic_measurement(truth, 8, freq_noise=0.002, shape_noise=0.02, seed=3, model_name=h.name)
    cal = calibrate(h, data, 0.002, 0.02)
    st, obs, base = cal.setting, cal.obs, cal.base
    seen = {}
    real = screening.bounded_linear_fit
    monkeypatch.setattr(screening, "bounded_linear_fit", lambda r0, jac: seen.update(r0=r0, jac=jac) or real(r0, jac))
    z = screening.linear_bounded_moduli(obs, base, st.local, st.coords, st.n_modes, 6.0 / 7.0, 8.0 / 7.0)
    # the columns one model at a time, as the fit's data were built before the batches
    span = (8.0 / 7.0 - 6.0 / 7.0) * base.s * st.local.modulus
    terms = [st.local.stiffness(e.id, span[k]) for k, e in enumerate(st.model.elements)]
    mid = 0.5 * (6.0 / 7.0 + 8.0 / 7.0) * base.s * st.local.modulus
    start = st.model.with_element_moduli({e.id: float(mid[k]) for k, e in enumerate(st.model.elements)})
    modes = np.unique(base.pairing[base.pairing >= 0])
    first = screening.baseline(AffineModel(start), st.coords, st.n_modes, modes)
    r0 = obs.residuals(frequencies_hz(first.lam), first.phi_c, base.pairing)[0]
    dlam, dshape = screening.changes(first, terms)
    jac = np.column_stack([(obs.residuals(*screening._moved(first.lam, first.phi_c, modes, dlam[k], dshape[k], 1e-4),
                                          base.pairing)[0] - r0) / 1e-4 for k in range(len(terms))])
    assert jac.shape == (obs.n_residuals, len(st.model.elements)) and np.abs(jac).max() > 0
    np.testing.assert_array_equal(seen["r0"], r0)
    np.testing.assert_array_equal(seen["jac"], jac)
    np.testing.assert_array_equal(z, bounded_linear_fit(r0, jac))
