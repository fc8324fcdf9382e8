"""screening._adjoint, the adjoint block G_i = Z_i C^T of the first-order screen (Nelson's shape
derivative), against the spectral sum it stands for, Z_i = sum_{j != i} phi_j phi_j^T /
(lambda_j - lambda_i) over every mode of a small frame from a dense eigendecomposition
(scipy.linalg.eigh, no bordered matrix), and its two solvers against each other: CHOLMOD's
L D L^T of the bordered matrix in a fixed order (no pivoting) and SuperLU's pivoted LU (the
fallback where scikit-sparse is absent or the L D L^T's backward error is too large).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp

import fe_problem as fp
from fe_problem.diagnosis import screening

from test_sparse import grid_frame

needs_cholmod = pytest.mark.skipif(screening._cholmod is None, reason="scikit-sparse is not installed here")


def case():
    """A 3-bay, 6-storey frame fixed at its base (126 free DOFs) on the sparse path: K, M (CSC),
    all its modes (dense, M-normalised) and C^T for every third free DOF plus a coordinate
    without a free DOF (an all-zero column, as a measured supported DOF gives)."""
    system = fp.AffineModel(grid_frame(3, 6), (), solver="sparse", workers=1)
    k0, m0 = sp.csc_matrix(system.k0), sp.csc_matrix(system.m0)
    lam, phi = scipy.linalg.eigh(k0.toarray(), m0.toarray())
    n = k0.shape[0]
    rows = np.arange(0, n, 3)
    c_t = np.zeros((n, len(rows) + 1))
    c_t[rows, np.arange(len(rows))] = 1.0
    return k0, m0, lam, phi, c_t


def spectral(lam, phi, i, c_t):
    """Z_i C^T from the modes: sum over j != i of phi_j (phi_j^T C^T) / (lambda_j - lambda_i)."""
    others = np.arange(len(lam)) != i
    return (phi[:, others] / (lam[others] - lam[i])) @ (phi[:, others].T @ c_t)


@pytest.mark.parametrize("cholmod", [True, False])
def test_the_adjoint_block_is_the_spectral_sum_over_the_other_modes(cholmod, monkeypatch):
    if cholmod and screening._cholmod is None:
        pytest.skip("scikit-sparse is not installed here")
    if not cholmod:
        monkeypatch.setattr(screening, "_cholmod", None)
    k0, m0, lam, phi, c_t = case()
    assert np.all(np.diff(lam[:7]) > 1e-3 * lam[6])  # simple eigenvalues: Z_i is defined
    for i in range(6):
        g = screening._adjoint(k0, m0, lam[i], phi[:, i], c_t)
        ref = spectral(lam, phi, i, c_t)
        assert g.shape == (k0.shape[0] + 1, c_t.shape[1]) and g.flags.c_contiguous
        assert np.all(g[-1] == 0.0) and np.all(g[:, -1] == 0.0)
        # the reference carries eigh's rounding divided by the gaps, summed over 126 modes:
        # both solvers differ from it by at most 2.5e-12 of the block's largest entry (mode 6)
        np.testing.assert_allclose(g[:-1], ref, rtol=0, atol=1e-9 * np.abs(ref).max())


@needs_cholmod
def test_the_ldlt_solve_equals_superlus_and_an_unstable_one_falls_back(monkeypatch):
    k0, m0, lam, phi, c_t = case()
    for i in (0, 3, 5):
        ldlt = screening._adjoint(k0, m0, lam[i], phi[:, i], c_t)
        with monkeypatch.context() as mp:
            mp.setattr(screening, "_cholmod", None)
            lu = screening._adjoint(k0, m0, lam[i], phi[:, i], c_t)
        # two backward-stable solves of the same system: they differ by rounding amplified by
        # the bordered matrix's condition, measured at most 2.1e-13 of the largest entry
        np.testing.assert_allclose(ldlt, lu, rtol=0, atol=1e-10 * np.abs(lu).max())
        assert not np.array_equal(ldlt, lu)  # the L D L^T did solve (it is not SuperLU's result)
        with monkeypatch.context() as mp:  # a backward error above any bound: SuperLU's answer
            mp.setattr(screening, "ADJOINT_BACKWARD_TOL", -1.0)
            np.testing.assert_array_equal(screening._adjoint(k0, m0, lam[i], phi[:, i], c_t), lu)
