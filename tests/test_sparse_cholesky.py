"""The sparse solver's Cholesky path (CHOLMOD through scikit-sparse, issue 25) against the path
it replaced: SuperLU with ARPACK at tol=0. The frequencies must not move by more than 1e-10
relative, the shapes and sensitivities agree, and without scikit-sparse the solver falls back
to SuperLU with the same answers.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import fe_problem as fp
import fe_problem.sparse as fs
from fe_problem.modal import frequencies_hz
from fe_problem.terms import Terms

from test_sparse import grid_frame, hframe_with_everything

needs_cholmod = pytest.mark.skipif(fs._cholmod is None, reason="scikit-sparse is not installed here")


def solvers(model, parameters=()):
    """(today's path: SuperLU, ARPACK tol=0; the default path) for the same model."""
    system = fp.AffineModel(model, parameters, solver="sparse", workers=1)
    k, m = Terms(model, system.parameters).free_arrays()
    old = fs.SparseModalSolver(k, m, system.n_free, system.x0, model.name, workers=1, factorization="superlu",
                               arpack_tol=0.0, min_zero=system.n_rigid if system.mechanism is None else 0)
    return old, system._solver


def points(parameters, n, seed):
    lo, hi = np.array([p.lower for p in parameters]), np.array([p.upper for p in parameters])
    return lo + (hi - lo) * np.random.default_rng(seed).uniform(0.05, 0.95, (n, len(parameters)))


@needs_cholmod
def test_the_default_is_cholesky_and_frequencies_move_less_than_1e_10():
    m = grid_frame(14, 22)  # 990 free DOFs
    pars = fp.element_moduli(m, lower=1.8e11, upper=2.4e11)[:40]
    old, new = solvers(m, pars)
    assert new.factorization == "cholmod" and new.arpack_tol == fs.ARPACK_TOL == 1e-10
    assert old.n_rigid == new.n_rigid == 0 and old.sigma == pytest.approx(new.sigma, rel=1e-10)
    theta = points(pars, 4, 0)
    l_old, p_old, d_old = old.eigen_sensitivities(theta, 12)
    l_new, p_new, d_new = new.eigen_sensitivities(theta, 12)
    np.testing.assert_allclose(frequencies_hz(l_new), frequencies_hz(l_old), rtol=1e-10, atol=0)
    np.testing.assert_allclose(p_new, p_old, atol=1e-7 * np.abs(p_old).max())
    np.testing.assert_allclose(d_new, d_old, rtol=1e-6, atol=1e-8 * np.abs(d_old).max())


@needs_cholmod
def test_cholesky_on_a_free_free_frame_with_springs_releases_and_masses():
    m = hframe_with_everything()
    pars = (fp.Parameter("modulus", (1, 2, 3), 6e10, 8e10, 7.1e10),
            fp.Parameter("density", (6, 9), 2000.0, 3500.0, 2700.0),
            fp.Parameter("mass", (5,), 0.0, 1.0, 0.15),
            fp.Parameter("spring", (1,), 0.0, 1e5, 2e4),
            fp.Parameter("release", (5, 3), 1e3, 1e6, 1e5))
    old, new = solvers(m, pars)
    assert new.factorization == "cholmod" and old.n_rigid == new.n_rigid == 2
    theta = points(pars, 3, 1)
    np.testing.assert_allclose(frequencies_hz(new.eigen(theta, 10)[0]), frequencies_hz(old.eigen(theta, 10)[0]),
                               rtol=1e-10, atol=0)


@needs_cholmod
def test_the_analysis_is_kept_per_model_and_made_anew_after_pickling():
    m = grid_frame(9, 10)
    system = fp.AffineModel(m, solver="sparse", workers=1)
    s = system._solver
    before = system.eigen(system.x0[None], 6)[0]
    first = s._analysis()
    assert s._analysis() is first  # one symbolic analysis for every point
    copy = pickle.loads(pickle.dumps(s))  # how a worker process gets it
    assert copy._symbolic is None
    np.testing.assert_array_equal(copy.eigen(system.x0[None], 6)[0], before)


@needs_cholmod
def test_an_indefinite_point_is_one_clear_error_on_the_ldlt_path():
    # simplicial LDL^T (fs.CHOLMOD_MODE) factors an indefinite matrix without complaint, as
    # supernodal LL^T does not: the solver checks D, so a negative modulus still stops with the error
    m = grid_frame(9, 10)
    pars = (fp.Parameter("modulus", tuple(e.id for e in m.elements), 1.8e11, 2.4e11, 2.1e11),)
    system = fp.AffineModel(m, pars, solver="sparse", workers=1)
    assert system._solver.factorization == "cholmod"
    with pytest.raises(ValueError, match="K - sigma M is not positive definite at this point"):
        system.eigen(np.array([[-2.1e11]]), 4)
    assert np.all(system.eigen(np.array([[2.1e11]]), 4)[0] > 0)  # a positive point still solves


def test_without_scikit_sparse_the_solver_falls_back_to_superlu(monkeypatch):
    m = grid_frame(9, 10)
    x = np.array([2.0e11])
    pars = (fp.Parameter("modulus", tuple(e.id for e in m.elements), 1.8e11, 2.4e11, 2.1e11),)
    ref = fp.AffineModel(m, pars, solver="sparse", workers=1).eigen(x[None], 8)[0]
    monkeypatch.setattr(fs, "_cholmod", None)
    assert fs.default_factorization() == "superlu"
    system = fp.AffineModel(m, pars, solver="sparse", workers=1)
    assert system._solver.factorization == "superlu"
    np.testing.assert_allclose(system.eigen(x[None], 8)[0], ref, rtol=1e-10)
    with pytest.raises(ValueError, match="cholmod needs scikit-sparse"):
        k, mm = Terms(m, pars).free_arrays()
        fs.SparseModalSolver(k, mm, system.n_free, system.x0, "x", factorization="cholmod")

