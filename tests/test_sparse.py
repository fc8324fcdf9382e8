"""The sparse solver path against the dense one, finite differences and OpenSeesPy.

The dense batched path (full LAPACK eigen-decompositions, rigid modes projected out) is the
reference: the sparse path (shift-invert Lanczos on one CSR pattern) must give the same
frequencies to 1e-10 relative (1e-8 on the larger frames), the same mass-normalised shapes
and the same eigenvalue sensitivities, on free-free and supported frames with springs,
releases, lumped masses and parameters of every kind; a point's answer must not depend on
the batch it comes in or on the number of worker processes.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
import scipy.linalg

import fe_problem as fp
from fe_problem.assembly import SPARSE_MIN_DOFS, solver_path
from fe_problem.model import Element, FrameModel, Material, Node, Section, Spring, Support
from fe_problem.sparse import PARALLEL_MIN_DOFS
from fe_problem.suite import storey_frame


def grid_frame(bays: int, storeys: int) -> FrameModel:
    """A regular steel frame fixed at its base (built here, independently of the benchmarks')."""
    cols = bays + 1
    nid = lambda s, c: s * cols + c + 1  # noqa: E731
    nodes = tuple(Node(nid(s, c), 5.0 * c, 3.2 * s) for s in range(storeys + 1) for c in range(cols))
    pairs = [(nid(s, c), nid(s + 1, c)) for s in range(storeys) for c in range(cols)]
    pairs += [(nid(s, c), nid(s, c + 1)) for s in range(1, storeys + 1) for c in range(bays)]
    return FrameModel(name=f"grid{bays}x{storeys}", nodes=nodes, materials={"s": Material(2.1e11, 7850.0, 0.3)},
                      sections={"c": Section(1e-2, 2e-4)},
                      elements=tuple(Element(k + 1, i, j, "c", "s") for k, (i, j) in enumerate(pairs)),
                      supports=tuple(Support(nid(0, c), ("x", "y", "rz")) for c in range(cols)))


def both(model, parameters=(), **kw):
    return fp.AffineModel(model, parameters, solver="dense"), fp.AffineModel(model, parameters, solver="sparse", **kw)


def assert_same_modes(dense, sparse, theta, n_modes, rtol=1e-10):
    ld, pd = dense.eigen(theta, n_modes, vectors=True)
    ls, ps = sparse.eigen(theta, n_modes, vectors=True)
    np.testing.assert_allclose(ls, ld, rtol=rtol)
    scale = np.abs(pd).max(axis=1, keepdims=True)
    # each path signs a shape by its largest entry; on a symmetric frame two entries tie, so
    # compare up to sign (and check the rule where the largest entry is clear)
    sign = np.sign(np.einsum("bim,bim->bm", ps, pd))[:, None, :]
    np.testing.assert_allclose(ps * sign / scale, pd / scale, atol=1e-7)
    top2 = np.sort(np.abs(pd), axis=1)[:, -2:, :]
    clear = (top2[:, 1] - top2[:, 0]) > 1e-6 * top2[:, 1]
    assert np.all(sign[:, 0, :][clear] == 1.0)
    lv, _ = sparse.eigen(theta, n_modes)  # eigenvalues only: the same numbers
    np.testing.assert_allclose(lv, ls, rtol=1e-12)
    return ls


def hframe_with_everything():
    """The H-frame with a flexible joint, a lumped mass, a spring to ground and a crack split."""
    m = fp.load_model("hframe")
    m = fp.release_element_end(m, 5, 3, 1e5)
    m = fp.add_mass(m, 5, 0.15, 6e-5)
    m = m.replace(springs=(Spring(1, (10, "y"), None, 2e4),))
    return fp.split_element(m, 4, 0.37, 1e5)


def test_free_free_hframe_forced_sparse_equals_dense():
    m = fp.load_model("hframe")
    pars = fp.element_moduli(m)
    dense, sparse = both(m, pars)
    assert (dense.path, sparse.path) == ("dense", "sparse")
    assert sparse.n_rigid == dense.n_rigid == 3 and sparse.n_elastic == 36 and sparse.mechanism is None
    theta = np.random.default_rng(1).uniform(6e10, 8e10, (4, 12))
    lam = assert_same_modes(dense, sparse, theta, 12)
    assert np.all(np.diff(lam, axis=1) > 0) and lam[0, 0] > 1e4  # no rigid mode left in


def test_every_parameter_kind_on_a_frame_with_springs_releases_and_masses():
    m = hframe_with_everything()
    e0 = 7.1e10
    pars = (fp.Parameter("modulus", (1, 2, 3), 6e10, 8e10, e0),
            fp.Parameter("modulus", (7,), 1e9, 8e10, e0, profile="middle"),
            fp.Parameter("density", (6, 9), 2000.0, 3500.0, 2700.0),
            fp.Parameter("mass", (5,), 0.0, 1.0, 0.15),
            fp.Parameter("spring", (1,), 0.0, 1e5, 2e4),
            fp.Parameter("release", (5, 3), 1e3, 1e7, 1e5))
    dense, sparse = both(m, pars)
    assert not dense._solver.mass_constant and sparse.n_rigid == dense.n_rigid == 2  # the spring holds one
    rng = np.random.default_rng(2)
    lo, hi = np.array([p.lower for p in pars]), np.array([p.upper for p in pars])
    theta = lo + (hi - lo) * rng.uniform(0.05, 0.95, (3, len(pars)))
    # a stiff joint spring (up to 1e7 N m/rad) beside a varying mass: the dense path's
    # mass-normalised operator keeps 4e-10 here, the sparse one 2e-11 of scipy's generalized eigh
    lam = assert_same_modes(dense, sparse, theta, 10, rtol=1e-9)
    for i in range(len(theta)):
        k, mm = dense.stiffness(theta[i:i + 1])[0], dense.mass(theta[i:i + 1])[0]
        ref = scipy.linalg.eigh(k, mm, eigvals_only=True)[2:12]
        np.testing.assert_allclose(lam[i], ref, rtol=1e-10)
    _, _, gd = dense.eigen_sensitivities(theta, 10)
    _, _, gs = sparse.eigen_sensitivities(theta, 10)
    scale = np.abs(gd).max(axis=(0, 1))  # per parameter: their units differ by 1e15
    np.testing.assert_allclose(gs / scale, gd / scale, rtol=1e-6, atol=1e-8)


def test_dense_path_with_a_varying_mass_refines_its_eigenvalues_and_sensitivities_follow():
    # M varies with theta: the dense path refines each eigenvalue by the Rayleigh quotient on
    # K and M, so its eigenvalues-only answer is the vectors path's, exactly, and the
    # sensitivities phi^T (dK - lambda dM) phi match central differences of those eigenvalues
    m = hframe_with_everything()
    pars = (fp.Parameter("modulus", (1, 2, 3), 6e10, 8e10, 7.1e10),
            fp.Parameter("density", (6, 9), 2000.0, 3500.0, 2700.0),
            fp.Parameter("mass", (5,), 0.0, 1.0, 0.15),
            fp.Parameter("spring", (1,), 0.0, 1e5, 2e4),
            fp.Parameter("release", (5, 3), 1e3, 1e7, 1e5))
    dense = fp.AffineModel(m, pars, solver="dense")
    assert not dense._solver.mass_constant
    x = np.array([7.5e10, 3100.0, 0.4, 6e4, 8e6])  # the stiff end of the joint spring
    lam, phi, g = dense.eigen_sensitivities(x[None], 8)
    assert np.array_equal(dense.eigen(x[None], 8)[0], lam)
    mm = dense.mass(x[None])[0]
    np.testing.assert_allclose(np.einsum("im,ij,jn->mn", phi[0], mm, phi[0]), np.eye(8), atol=1e-12)
    for k in range(len(pars)):
        h = 1e-6 * x[k]
        up, dn = x.copy(), x.copy()
        up[k] += h
        dn[k] -= h
        fd = (dense.eigen(up[None], 8)[0] - dense.eigen(dn[None], 8)[0])[0] / (2 * h)
        np.testing.assert_allclose(g[0, :, k], fd, rtol=1e-4, atol=1e-5 * np.abs(g[0, :, k]).max())


def test_sparse_sensitivities_equal_finite_differences():
    m = grid_frame(3, 4)
    pars = fp.element_moduli(m, lower=1.5e11, upper=2.5e11)[:8] + (
        fp.Parameter("density", tuple(range(9, 20)), 6000.0, 9000.0, 7850.0),)
    sparse = fp.AffineModel(m, pars, solver="sparse")
    x = np.append(np.linspace(1.8e11, 2.3e11, 8), 7000.0)
    lam, _, g = sparse.eigen_sensitivities(x[None], 6)
    for k in (0, 5, 8):
        h = 1e-6 * x[k]
        up, dn = x.copy(), x.copy()
        up[k] += h
        dn[k] -= h
        fd = (sparse.eigen(up[None], 6)[0] - sparse.eigen(dn[None], 6)[0])[0] / (2 * h)
        np.testing.assert_allclose(g[0, :, k], fd, rtol=1e-5, atol=1e-6 * np.abs(lam).max() / x[k])


def test_supported_storey_frame_with_floor_masses():
    m = storey_frame(40)  # 246 free DOFs, fixed base, lumped floor masses
    pars = fp.element_moduli(m, lower=1.8e11, upper=2.4e11)
    dense, sparse = both(m, pars)
    assert dense.n_rigid == sparse.n_rigid == 0
    theta = np.random.default_rng(3).uniform(1.8e11, 2.4e11, (2, len(pars)))
    assert_same_modes(dense, sparse, theta, 10)


def test_a_frame_of_1500_dofs_equals_the_dense_reference_to_1e_8():
    m = grid_frame(9, 50)  # 1,500 free DOFs
    dense, sparse = both(m)
    assert sparse.n_free == 1500 and fp.AffineModel(m).path == "sparse"
    assert_same_modes(dense, sparse, np.zeros((1, 0)), 10, rtol=1e-8)


def test_a_mechanism_is_found_and_named_on_the_sparse_path_too():
    m = fp.release_element_end(fp.load_model("hframe"), 5, 3, 0.0)  # a pin: a fourth zero mode
    dense, sparse = both(m)
    assert sparse.n_rigid == dense.n_rigid == 4
    # the crossbar and right upright turn as one body: their rotations tie, so which four are
    # named may differ; the count and the kind of motion may not
    for system in (dense, sparse):
        assert system.mechanism.startswith("1 mechanism motion(s) strain no element and no spring (moving most: node")
        assert system.mechanism.count(" rz") == 4
    assert_same_modes(dense, sparse, np.zeros((1, 0)), 8)


def test_the_path_is_chosen_by_size_and_can_be_forced():
    small, large = storey_frame(10), grid_frame(9, 10)
    assert fp.AffineModel(small).path == "dense" and fp.AffineModel(large).path == "sparse"
    assert fp.AffineModel(large).n_free == 300 > SPARSE_MIN_DOFS >= fp.AffineModel(small).n_free
    assert solver_path(SPARSE_MIN_DOFS) == "dense" and solver_path(SPARSE_MIN_DOFS + 1) == "sparse"
    assert solver_path(10, "sparse") == "sparse" and solver_path(10**6, "dense") == "dense"
    assert solver_path(150, n_params=3000) == "sparse"  # a small model with very many parameters
    with pytest.raises(ValueError, match="solver must be one of"):
        fp.AffineModel(small, solver="banded")


def test_a_point_does_not_depend_on_its_batch_or_the_worker_count():
    m = grid_frame(9, 35)  # 1,050 free DOFs: batches go to worker processes
    pars = fp.element_moduli(m, lower=1.8e11, upper=2.4e11)
    one = fp.AffineModel(m, pars, workers=1)
    two = fp.AffineModel(m, pars, workers=2)
    assert one.n_free >= PARALLEL_MIN_DOFS and two.path == "sparse"
    theta = np.random.default_rng(4).uniform(1.8e11, 2.4e11, (3, len(pars)))
    rows = two.nodal_rows([(12, "x"), (40, "y"), (1, "x")])  # node 1 is supported: row -1
    lam2, phi2 = two.eigen(theta, 8, vectors=True, rows=rows)
    lam1, phi1 = one.eigen(theta, 8, vectors=True, rows=rows)
    assert np.array_equal(lam1, lam2) and np.array_equal(phi1, phi2)
    for i in range(3):
        lam, phi = one.eigen(theta[i:i + 1], 8, vectors=True)
        assert np.array_equal(lam[0], lam2[i]) and np.array_equal(one.at_rows(phi, rows)[0], phi2[i])
    assert np.all(phi2[:, 2] == 0.0)


def test_updating_problem_on_the_sparse_path_equals_the_dense_one():
    truth = fp.crack_element(fp.load_model("hframe"), 7, 0.3, 3e4)
    data = fp.synthetic_measurement(truth, n_modes=6, seed=1, model_name="hframe")
    dense = fp.UpdatingProblem("hframe", data, shape_weight=0.5, solver="dense")
    sparse = fp.UpdatingProblem("hframe", data, shape_weight=0.5, solver="sparse")
    assert sparse.system.path == "sparse"
    X = np.random.default_rng(5).uniform(dense.xl, dense.xu, (5, dense.n_var))
    np.testing.assert_allclose(sparse.evaluate(X), dense.evaluate(X), rtol=1e-9)
    ls, ld = sparse.least_squares(X[0]), dense.least_squares(X[0])
    np.testing.assert_allclose(ls.residuals, ld.residuals, rtol=1e-9, atol=1e-14)
    m = data.n_modes  # the frequency rows: analytic eigenvalue derivatives on both paths
    fj_s, fj_d = ls.jacobian[:m], ld.jacobian[:m]
    np.testing.assert_allclose(fj_s, fj_d, rtol=1e-7, atol=1e-9 * np.abs(fj_d).max())
    # the shape rows are forward differences with a step h of 1e-6 of each range
    # (UpdatingProblem._shape_jacobian): where the two paths' shape residuals agree to delta at
    # x and at the stepped points, their differences agree to 2 delta / h
    h = 1e-6 * (dense.xu - dense.xl)
    steps = X[:1] + np.diag(h)

    def shape_rows(p, x):
        return p.shape_residuals(p.system.eigen(x, p.n_model_modes, vectors=True, rows=p.rows)[1])

    delta = max(np.abs(shape_rows(sparse, pts) - shape_rows(dense, pts)).max() for pts in (X[:1], steps))
    assert delta < 1e-12  # the two paths' shapes agree
    np.testing.assert_allclose(ls.jacobian[m:], ld.jacobian[m:], rtol=1e-7, atol=2 * delta / h.min())
    np.testing.assert_allclose(sparse.correlation(X[1]).mac, dense.correlation(X[1]).mac, rtol=1e-9)


def test_modal_analysis_of_a_large_free_free_frame_takes_the_sparse_path():
    m = grid_frame(8, 12).replace(supports=())  # 351 free DOFs, no supports: 3 rigid-body modes
    res = fp.modal_analysis(m, 6)
    dense = fp.AffineModel(m, solver="dense")
    lam, phi = dense.eigen(np.zeros((1, 0)), 6, vectors=True)
    assert res.n_rigid == 3 and res.path == "sparse" and fp.modal_analysis(m, 6, solver="dense").path == "dense"
    np.testing.assert_allclose((2 * np.pi * res.frequencies_hz) ** 2, lam[0], rtol=1e-10)
    np.testing.assert_allclose(res.shapes, dense.expand(phi[0]), atol=1e-7 * np.abs(res.shapes).max())


def test_a_300_dof_frame_on_the_sparse_path_agrees_with_opensees_to_1e_8():
    from test_opensees import opensees_modes  # OpenSeesPy's full generalized LAPACK solver

    m = grid_frame(9, 10)
    res = fp.modal_analysis(m, 10)
    assert fp.AffineModel(m).path == "sparse" and res.n_rigid == 0
    hz, shapes, n_zero = opensees_modes(m, 10)
    assert n_zero == 0
    np.testing.assert_allclose(res.frequencies_hz, hz, rtol=1e-8)
    assert np.all(np.diag(fp.mac(res.shapes, shapes)) > 1 - 1e-10)


def test_a_long_thin_free_free_beam_keeps_its_three_rigid_modes_and_no_dense_matrix():
    # 1,500 nodes 1 cm apart: K's condition number is about 1e13, so the rigid-body eigenvalues
    # come out far from zero; they are known from the geometry and dropped all the same
    n = 1500
    m = FrameModel(name="thin", nodes=tuple(Node(i + 1, 0.01 * i, 0.0) for i in range(n)),
                   materials={"m": Material(7e10, 2700.0, 0.33)}, sections={"s": Section(1e-4, 1e-9)},
                   elements=tuple(Element(i + 1, i + 1, i + 2, "s", "m") for i in range(n - 1)))
    tracemalloc.start()
    try:
        res = fp.modal_analysis(m, 4)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert res.n_rigid == 3 and res.mechanism is None
    assert peak < 60 * 2**20  # one dense 4,500 x 4,500 matrix alone would be 162 MB
    L = 0.01 * (n - 1)
    beta_l = np.array([4.730040745, 7.853204624, 10.99560784, 14.13716549])  # free-free beam
    exact = beta_l**2 / (2 * np.pi * L**2) * np.sqrt(7e10 * 1e-9 / (2700 * 1e-4))
    np.testing.assert_allclose(res.frequencies_hz, exact, rtol=1e-5)
    # docs/scale-method.md: the first elastic frequency off the closed form "now X and Y" with
    # CHOLMOD and SuperLU (the Rayleigh quotients), to the page's printed precision
    import re
    from pathlib import Path

    import fe_problem.sparse as fs
    from fe_problem.terms import Terms

    page = " ".join((Path(__file__).resolve().parents[1] / "docs" / "scale-method.md").read_text().split())
    said = re.search(r"the quotient to its square: now ([\d.]+e-\d+) and ([\d.]+e-\d+), what", page)
    assert said, "docs/scale-method.md: the thin beam's errors not found"
    system = fp.AffineModel(m, (), solver="sparse", workers=1)
    k, mm = Terms(m, system.parameters).free_arrays()
    for fac, printed in zip(fs.FACTORIZATIONS, said.groups()):
        if fac == "cholmod" and fs._cholmod is None:
            continue  # the 'cholmod' extra absent: SuperLU's figure alone
        s = fs.SparseModalSolver(k, mm, system.n_free, system.x0, "thin", workers=1, factorization=fac,
                                 min_zero=system.n_rigid)
        first = np.sqrt(s._modes(system.x0, 4, False, None, False)[0][0]) / (2 * np.pi)
        assert f"{abs(first / exact[0] - 1):.0e}".replace("e-0", "e-") == printed, (fac, first / exact[0] - 1)


def test_least_squares_with_hundreds_of_parameters_on_a_1000_dof_frame():
    m = grid_frame(9, 35)
    m = m.replace(measured_dofs=tuple((n, "x") for n in range(20, 361, 10)))
    pars = fp.element_moduli(m, lower=1.8e11, upper=2.4e11)  # 665 parameters
    rng = np.random.default_rng(6)
    truth = rng.uniform(1.9e11, 2.3e11, len(pars))
    data = fp.synthetic_measurement(m, 6, parameters=pars, theta=truth, seed=1)
    problem = fp.UpdatingProblem(m, data, parameters=pars, n_model_modes=8)
    assert problem.system.path == "sparse" and problem.n_var == 665 and problem.system.n_free == 1050
    x = rng.uniform(1.9e11, 2.3e11, len(pars))
    ls = problem.least_squares(x)
    assert ls.jacobian.shape == (6, 665)
    np.testing.assert_allclose(ls.f, problem.evaluate(x)[0], rtol=1e-12)
    for k in (0, 333, 664):
        h = 1e-3 * x[k]  # the eigen-solver's 1e-14 noise must stay far below the step's effect
        up, dn = x.copy(), x.copy()
        up[k] += h
        dn[k] -= h
        fd = (problem.residuals(up)[0] - problem.residuals(dn)[0]) / (2 * h)
        np.testing.assert_allclose(ls.jacobian[:, k], fd, rtol=1e-4, atol=1e-6 * np.abs(ls.jacobian).max())


def test_a_batch_survives_a_worker_process_that_dies():
    import os
    import signal
    import time

    import fe_problem._pool

    m = grid_frame(9, 10)
    system = fp.AffineModel(m, workers=2)
    theta = np.zeros((4, 0))
    for wait_s in (0.0, 1.0):  # the death seen when the results are collected, or already at submit
        lam, _ = system.eigen(theta, 6)  # (re)starts the shared pool
        pids = fe_problem._pool.worker_pids()
        assert pids  # the batch did use a worker
        for pid in pids:
            os.kill(pid, signal.SIGKILL)
        time.sleep(wait_s)
        again, _ = system.eigen(theta, 6)  # the dead worker's share done here, or by a new pool
        assert np.array_equal(again, lam) and np.all(again == again[0])
    assert np.array_equal(system.eigen(theta, 6)[0], lam) and fe_problem._pool.worker_pids()


def test_a_lanczos_run_that_does_not_converge_is_retried_wider_then_named(monkeypatch):
    import fe_problem.sparse as fs
    from scipy.sparse.linalg import ArpackNoConvergence

    system = fp.AffineModel(grid_frame(9, 10), workers=1)
    reference, _ = system.eigen(np.zeros((1, 0)), 6)
    real, calls = fs.eigsh, []

    def flaky(*args, **kw):
        calls.append(kw["ncv"])
        if len(calls) == 1:
            raise ArpackNoConvergence("ARPACK error -1: No convergence", np.zeros(0), np.zeros((0, 0)))
        return real(*args, **kw)

    monkeypatch.setattr(fs, "eigsh", flaky)
    lam, _ = system.eigen(np.zeros((1, 0)), 6)
    assert calls == [20, 40]
    np.testing.assert_allclose(lam, reference, rtol=1e-12)

    def never(*args, **kw):
        raise ArpackNoConvergence("ARPACK error -1: No convergence", np.zeros(0), np.zeros((0, 0)))

    monkeypatch.setattr(fs, "eigsh", never)
    with pytest.raises(ValueError, match="'grid9x10': the Lanczos iteration for the lowest 6 modes did not converge"):
        system.eigen(np.zeros((1, 0)), 6)


def test_the_processes_of_a_batch_follow_the_environment_and_study_runs_use_one(monkeypatch):
    import fe_problem.sparse as fs
    from femu.studies import child

    monkeypatch.setenv(fs.WORKERS_ENV, "3")
    assert fs.default_workers() == 3 and fp.AffineModel(grid_frame(9, 10)).workers == 3
    monkeypatch.setenv(fs.WORKERS_ENV, "many")
    with pytest.raises(ValueError, match="FEMU_SOLVER_WORKERS='many': not a whole number"):
        fs.default_workers()
    # a run on a Dask worker is a fresh interpreter: its batches stay in it (the cluster's
    # processes are the parallelism there); the env it is started with says so
    seen = {}

    class Stop(Exception):
        pass

    def popen(args, env, **kw):
        seen.update(env)
        raise Stop

    monkeypatch.setattr(child.subprocess, "Popen", popen)
    monkeypatch.setattr(child, "asdict", lambda task: {})
    with pytest.raises(Stop):
        child.run_task_in_child(None)
    assert seen[fs.WORKERS_ENV] == "1"


def test_the_dense_path_keeps_the_first_real_mode_of_a_fine_mesh():
    """The H-frame split 16 times (579 DOFs): its axial stiffness is ~1e12 times its first
    bending mode's, which a zero-mode test relative to the largest eigenvalue took for a fourth
    rigid-body mode (the dense path dropped the 56 Hz mode)."""
    from fe_problem.suite import split_hframe

    m = split_hframe(16)
    pars = fp.element_moduli(m)[:2]  # two parameters: the rest of the model is the constant part
    dense, sparse = (fp.AffineModel(m, pars, solver=s) for s in ("dense", "sparse"))
    assert (dense.n_rigid, dense.mechanism) == (3, None) == (sparse.n_rigid, sparse.mechanism)
    lam_d, _ = dense.eigen(dense.x0[None, :], 8)
    lam_s, _ = sparse.eigen(sparse.x0[None, :], 8)
    np.testing.assert_allclose(lam_d, lam_s, rtol=1e-8)
    assert 56.0 < np.sqrt(lam_d[0, 0]) / (2 * np.pi) < 56.5


def _counting_points(monkeypatch):
    """The eigen-solves (`SparseModalSolver._point` calls) made from here on, counted."""
    from fe_problem.sparse import SparseModalSolver
    calls = []
    original = SparseModalSolver._point

    def counted(self, *args, **kw):
        calls.append(args[1])
        return original(self, *args, **kw)
    monkeypatch.setattr(SparseModalSolver, "_point", counted)
    return calls


@pytest.mark.parametrize("case,n_modes,n_rigid,solves", [
    ("grid", 10, 0, 1),        # supported, 1,500 DOFs: the count's solve gives the 10 modes
    ("free", 8, 3, 1),         # free-free: three rigid-body modes dropped, 3 + 8 within the 12
    ("free", 12, 3, 1),        # 3 + 12: the count's solve widened to 15
    ("mechanism", 8, 4, 1),    # a pin: a mechanism beyond the rigid motions, 4 + 8 within the 12
    ("mechanism", 9, 4, 2),    # 4 + 9 > 12 (the geometry foresaw 3): solved again, as without x0_modes
])
def test_a_model_solved_at_x0_counts_and_solves_in_one_eigen_solve(monkeypatch, case, n_modes, n_rigid, solves):
    """`x0_modes`: a model with no parameter gets its zero-energy count and its modes from one
    ARPACK run (at the count's shift), equal to the dense LAPACK reference (1e-8 relative, the
    shapes to 1e-7 of their largest entry) and to the default two-solve path (1e-10)."""
    m = {"grid": lambda: grid_frame(9, 50), "free": lambda: fp.load_model("hframe"),
         "mechanism": lambda: fp.release_element_end(fp.load_model("hframe"), 5, 3, 0.0)}[case]()
    dense = fp.AffineModel(m, solver="dense")
    default = fp.AffineModel(m, solver="sparse")
    calls = _counting_points(monkeypatch)
    once = fp.AffineModel(m, solver="sparse", x0_modes=n_modes)
    once.eigen(np.zeros((1, 0)), n_modes, vectors=True)
    assert len(calls) == solves + (1 if case == "mechanism" else 0)  # + the mechanism's naming solve
    assert (once.n_rigid, once.n_elastic, once.mechanism is None) == \
        (default.n_rigid, default.n_elastic, default.mechanism is None) and once.n_rigid == n_rigid
    lam = assert_same_modes(dense, once, np.zeros((1, 0)), n_modes, rtol=1e-8)
    np.testing.assert_allclose(lam, default.eigen(np.zeros((1, 0)), n_modes)[0], rtol=1e-10)


def test_eigshs_operators_are_the_plain_product_and_solve_to_the_bit(monkeypatch):
    """`_point` hands eigsh the CSR product and the factor's solve as bare functions (`_Direct`,
    `_csr_product`): the same vectors as `M @ v` and as eigsh's run on plain LinearOperators."""
    import fe_problem.sparse as fs
    from scipy.sparse.linalg import LinearOperator

    model = grid_frame(9, 10)
    pars = fp.element_moduli(model, lower=1.8e11, upper=2.4e11)[:6]
    system = fp.AffineModel(model, pars, solver="sparse", workers=1)
    solver, theta = system._solver, np.linspace(1.9e11, 2.3e11, 6)
    _, md, _, mmat = solver._matrices(theta)
    v = np.random.default_rng(3).standard_normal(solver.n_free)
    product = fs._csr_product(mmat)
    assert getattr(product, "__self__", None) is None  # scipy's kernel, not `mmat @`
    np.testing.assert_array_equal(product(v), mmat @ v)
    np.testing.assert_array_equal(product(v[::-1]), mmat @ v[::-1])  # a strided view, as ARPACK's slices are not
    op = fs._Direct(product, solver.n_free)
    assert op.matvec is product and op.shape == (solver.n_free,) * 2 and np.array_equal(op @ v, mmat @ v)
    with monkeypatch.context() as mp:  # without scipy's kernel where it was: the product itself
        mp.setattr(fs.sp, "_sparsetools", None)
        np.testing.assert_array_equal(fs._csr_product(mmat)(v), mmat @ v)

    new = solver._point(theta, 10, vectors=True)
    real = fs.eigsh

    def plain(a, **kw):  # the operators as they were: LinearOperators around the same functions
        n = a.shape[0]
        kw["M"] = LinearOperator((n, n), matvec=lambda x: mmat @ x, dtype=float)
        kw["OPinv"] = LinearOperator((n, n), matvec=kw["OPinv"].matvec, dtype=float)
        return real(a, **kw)

    monkeypatch.setattr(fs, "eigsh", plain)
    old = solver._point(theta, 10, vectors=True)
    np.testing.assert_array_equal(new[0], old[0])
    np.testing.assert_array_equal(new[1], old[1])


def test_the_bare_operators_keep_linearoperators_shapes_or_refuse():
    """Outside eigsh's (n,) float64 vectors: `op @ X` of a `_Direct` for X (n, k) is (n, k), each
    column the product or solve of that column (LinearOperator's default stacked the (n,)
    results into one (k n,) vector), and `_csr_product` refuses a vector of another length (the
    kernel would read past it), a column (n, 1) (also as `op @ X`, which LinearOperator sends to
    matvec) and complex values with ValueError."""
    import fe_problem.sparse as fs

    system = fp.AffineModel(grid_frame(3, 6), (), solver="sparse", workers=1)
    solver = system._solver
    kd, md, _, mmat = solver._matrices(system.x0)
    n = solver.n_free
    x = np.random.default_rng(5).standard_normal((n, 3))
    product = fs._csr_product(mmat)
    solve = solver._factor(kd - solver.sigma * md)
    for f, ref in ((product, mmat @ x), (solve, np.column_stack([solve(x[:, j].copy()) for j in range(3)]))):
        op = fs._Direct(f, n)
        for got in (op @ x, op.matmat(x), op @ x[:, :2]):
            assert got.shape == (n, got.shape[1]) and got.shape[1] in (2, 3)
            np.testing.assert_array_equal(got, ref[:, :got.shape[1]])
    np.testing.assert_array_equal(fs._Direct(product, n) @ x[:, 1], mmat @ x[:, 1])
    for bad in (x[:-1, 0], x[:, :1], x[:, 0] + 0j):
        with pytest.raises(ValueError, match="float64"):
            product(bad)
    with pytest.raises(ValueError, match="float64"):  # LinearOperator sends (n, 1) to matvec
        fs._Direct(product, n) @ x[:, :1]


def test_the_sign_rule_is_the_one_written_column_by_column_to_the_bit():
    """solver.signed (column maxima by halving, `_column_max`) against the rule written out
    per shape: the first row within SIGN_TIE of the largest |entry| decides, made positive."""
    from fe_problem.solver import SIGN_TIE, signed

    def by_column(phi):
        out = phi.copy()
        for idx in np.ndindex(phi.shape[:-2] + phi.shape[-1:]):
            col = phi[idx[:-1] + (slice(None), idx[-1])]
            first = next(i for i, x in enumerate(np.abs(col)) if x >= (1.0 - SIGN_TIE) * np.abs(col).max())
            out[idx[:-1] + (slice(None), idx[-1])] = col * (-1.0 if col[first] < 0 else 1.0)
        return out

    rng = np.random.default_rng(5)
    tie = np.zeros((7, 3))
    tie[[2, 5], 0] = [-1.0, 1.0]                # equal and opposite: the lower row decides
    tie[[1, 4], 1] = [0.5, -0.5 * (1 + 1e-9)]  # the second larger within the tie: the first decides
    tie[[1, 4], 2] = [0.5, -0.5 * (1 + 1e-7)]  # beyond the tie: the largest decides
    for phi in (rng.standard_normal((3025, 14)), rng.standard_normal((3, 301, 5)), rng.standard_normal((1, 4)),
                rng.standard_normal((40, 9))[::3, 1:], np.asfortranarray(rng.standard_normal((3024, 14))), tie):
        np.testing.assert_array_equal(signed(phi), by_column(phi))
    assert signed(tie)[1, 1] == 0.5 and signed(tie)[4, 2] > 0.0
