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
    """A 3-bay, 6-storey frame fixed at its base (72 free DOFs) on the sparse path: K, M (CSC),
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
def test_the_adjoint_block_is_the_spectral_sum_over_the_other_modes(cholmod):
    if cholmod and screening._cholmod is None:
        pytest.skip("scikit-sparse is not installed here")
    k0, m0, lam, phi, c_t = case()
    assert np.all(np.diff(lam[:7]) > 1e-3 * lam[6])  # simple eigenvalues: Z_i is defined
    for i in range(6):
        g = screening._adjoint(k0, m0, lam[i], phi[:, i], c_t, ldlt=cholmod)
        ref = spectral(lam, phi, i, c_t)
        assert g.shape == (k0.shape[0] + 1, c_t.shape[1]) and g.flags.c_contiguous
        assert np.all(g[-1] == 0.0) and np.all(g[:, -1] == 0.0)
        # the reference carries eigh's rounding divided by the gaps, summed over 72 modes:
        # both solvers differ from it by at most 2.5e-12 of the block's largest entry (the sixth mode, i = 5)
        np.testing.assert_allclose(g[:-1], ref, rtol=0, atol=1e-9 * np.abs(ref).max())


@needs_cholmod
def test_the_ldlt_solve_equals_superlus_and_an_unstable_one_falls_back(monkeypatch):
    k0, m0, lam, phi, c_t = case()
    for i in (0, 3, 5):
        ldlt = screening._adjoint(k0, m0, lam[i], phi[:, i], c_t, ldlt=True)
        lu = screening._adjoint(k0, m0, lam[i], phi[:, i], c_t, ldlt=False)
        # two backward-stable solves of the same system: they differ by rounding amplified by
        # the bordered matrix's condition, measured at most 2.1e-13 of the largest entry
        np.testing.assert_allclose(ldlt, lu, rtol=0, atol=1e-10 * np.abs(lu).max())
        assert not np.array_equal(ldlt, lu)  # the L D L^T did solve (it is not SuperLU's result)
        with monkeypatch.context() as mp:  # a backward error above any bound: SuperLU's answer
            mp.setattr(screening, "ADJOINT_BACKWARD_TOL", -1.0)
            np.testing.assert_array_equal(screening._adjoint(k0, m0, lam[i], phi[:, i], c_t, ldlt=True), lu)


def corrupting(monkeypatch, change):
    """CHOLMOD as it is, except that the L D L^T's solve passes its result (n + 1, n_coord, in
    `_adjoint_ldlt`'s elimination order `perm`) through change(x, perm) before the check."""
    real, order, seen = screening._cholmod, screening._bordered_order, {}

    def record(bordered, phi):
        seen["perm"] = order(bordered, phi)
        return seen["perm"]

    class Factor:
        def __init__(self, factor):
            self.factor = factor

        def solve_A(self, r):
            x = self.factor.solve_A(r)
            change(x, seen["perm"])
            return x

    class Analysis:
        def __init__(self, analysis):
            self.analysis = analysis

        def P(self):
            return self.analysis.P()

        def cholesky(self, a):
            return Factor(self.analysis.cholesky(a))

    class Cholmod:
        CholmodError = real.CholmodError

        @staticmethod
        def analyze(a, **kw):
            return Analysis(real.analyze(a, **kw))

    monkeypatch.setattr(screening, "_cholmod", Cholmod)
    monkeypatch.setattr(screening, "_bordered_order", record)


@needs_cholmod
@pytest.mark.parametrize("along", ["entry", "phi"])
def test_a_solve_wrong_in_any_one_column_falls_back_to_superlu(along, monkeypatch):
    """One column of the L D L^T's solution made wrong by 1e-8 of its largest entry, at that
    entry or along phi (the null vector of K - lam M, which only the border's row sees), whichever
    column it is: the check of every column sees it and `_adjoint` returns SuperLU's solve."""
    k0, m0, lam, phi, c_t = case()
    n, n_coord = c_t.shape
    for i in (0, 5):
        lu = screening._adjoint(k0, m0, lam[i], phi[:, i], c_t, ldlt=False)
        for j in range(n_coord - 1):  # the last column is zero (no free DOF): nothing to corrupt
            def change(x, perm):
                size = np.abs(x[:, j]).max()
                if along == "entry":
                    x[np.argmax(np.abs(x[:, j])), j] += 1e-8 * size
                else:
                    x[:, j] += 1e-8 * size * np.append(phi[:, i], 0.0)[perm]
            with monkeypatch.context() as mp:
                corrupting(mp, change)
                np.testing.assert_array_equal(screening._adjoint(k0, m0, lam[i], phi[:, i], c_t, ldlt=True), lu)
        with monkeypatch.context() as mp:  # the same wrapper with nothing changed: the L D L^T's own
            corrupting(mp, lambda x, perm: None)
            ldlt = screening._adjoint(k0, m0, lam[i], phi[:, i], c_t, ldlt=True)
        assert not np.array_equal(ldlt, lu)
        np.testing.assert_array_equal(ldlt, screening._adjoint(k0, m0, lam[i], phi[:, i], c_t, ldlt=True))


@needs_cholmod
def test_the_screen_uses_the_systems_own_factorisation(monkeypatch):
    """`baseline` solves by L D L^T only where the system's sparse solver factors by CHOLMOD: a
    system forced to SuperLU (and one on the dense path) gets SuperLU's blocks throughout."""
    import fe_problem.sparse as fs

    calls = []
    real = screening._adjoint_ldlt

    def counted(*args):
        calls.append(1)
        return real(*args)

    monkeypatch.setattr(screening, "_adjoint_ldlt", counted)
    model = grid_frame(3, 6)
    coords = [(node.id, "x") for node in model.nodes[::3]]
    cholmod = fp.AffineModel(model, (), solver="sparse", workers=1)
    assert cholmod._solver.factorization == "cholmod"
    screening.baseline(cholmod, coords, 4)
    assert len(calls) == 4
    with monkeypatch.context() as mp:
        mp.setattr(fs, "default_factorization", lambda: "superlu")
        superlu = fp.AffineModel(model, (), solver="sparse", workers=1)
    assert superlu._solver.factorization == "superlu"
    dense = fp.AffineModel(model, (), solver="dense")
    for system in (superlu, dense):
        base = screening.baseline(system, coords, 4)
        assert len(calls) == 4
        k0, m0 = sp.csc_matrix(system.k0), sp.csc_matrix(system.m0)
        c_t = np.zeros((system.n_free, len(coords)))
        rows = system.nodal_rows(coords)
        c_t[rows[rows >= 0], np.flatnonzero(rows >= 0)] = 1.0
        phi = base.phi_z[:-1]
        for i, g in zip(base.modes, base.g):
            np.testing.assert_array_equal(g, screening._adjoint(k0, m0, base.lam[i], phi[:, i], c_t, ldlt=False))
