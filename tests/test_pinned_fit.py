"""The pinned-moduli step's bounded linear fit on a compressed Jacobian (issue 25): the same
residual norm at every point as the full Jacobian, and the same fit as scipy's `least_squares`
run on the full problem."""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

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


def test_the_bounded_fit_equals_least_squares_on_the_full_jacobian():
    r0, jac = tall_problem(600, 150, 80, 3)
    full = least_squares(lambda z: r0 + jac @ (z - 0.5), np.full(150, 0.5), jac=lambda z: jac, bounds=(0.0, 1.0),
                         max_nfev=60, tr_solver="lsmr")
    z = bounded_linear_fit(r0, jac)
    cost = 0.5 * np.sum((r0 + jac @ (z - 0.5)) ** 2)
    assert np.all((z >= 0) & (z <= 1))
    assert abs(cost / full.cost - 1) < 1e-7
    # the same moduli pinned to a bound
    np.testing.assert_array_equal(np.isclose(z, 0, atol=1e-6) | np.isclose(z, 1, atol=1e-6),
                                  np.isclose(full.x, 0, atol=1e-6) | np.isclose(full.x, 1, atol=1e-6))
