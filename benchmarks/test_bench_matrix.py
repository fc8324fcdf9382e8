"""Matrix models: one evaluation of a model given as matrices at 10,000 and 100,000 DOFs against
the bare CHOLMOD + ARPACK floor on the same matrices.

The model: a regular planar steel frame (scale_frames.regular_frame) exported as matrices, the
way another FE program hands one over: four stiffness matrices (the columns and the beams of
the lower and of the upper half, each a parameter in [0.5, 1.5]) and one lumped mass matrix
(1,000 kg on x and y of every free node, nothing on the rotations: a third of the DOFs have no
mass, handled exactly). Written as .npz files and a manifest, read back by
`fe_problem.load_matrix_model`; measured data: its 10 lowest modes at a truth 5 % off, at 20
rows.

- `matrix_eval:N`: `UpdatingProblem.evaluate` of one point (10 modes, frequencies only) on
  the matrix model;
- `matrix_floor:N`: the bare recipe on the same K and M at that point: CHOLMOD's numeric
  factorisation of K - sigma M on an analysis made beforehand and scipy's `eigsh` in
  shift-invert mode with the same shift, start vector, Krylov size and tolerance.

conftest.py prints their ratio (goal: the evaluation within 1.3x of the floor). Before timing,
our frequencies are checked against the floor's (1e-10) and, at 10,000 DOFs, against scipy's
own shift-invert `eigsh` (sigma = 0, its own LU factorisation, default start) to 1e-8.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator, eigsh

import fe_problem as fp
import fe_problem.sparse
from fe_problem.modal import frequencies_hz
from fe_problem.modal_data import ModalData
from fe_problem.sparse import ARPACK_TOL
from scale_frames import STOREY_M, regular_frame

N_MODES = 10
#: about this many DOFs -> (bays, storeys): 3 (bays + 1) storeys free DOFs (10,050 and 100,200).
SIZES = {10000: (49, 67), 100000: (99, 334)}
ROUNDS = {10000: 5, 100000: 2}
_CACHE: dict[int, tuple] = {}


def export(n: int, folder) -> str:
    """The n-DOF frame's matrices written as a matrix model in `folder`: its manifest's path."""
    bays, storeys = SIZES[n]
    model = regular_frame(bays, storeys)
    half = storeys // 2
    groups: dict[str, list[int]] = {}
    for e in model.elements:
        upper = max(model.node(e.node_i).y, model.node(e.node_j).y) / STOREY_M > half
        groups.setdefault(f"{e.section}s_{'upper' if upper else 'lower'}", []).append(e.id)
    e0 = 2.1e11
    params = tuple(fp.Parameter("modulus", tuple(ids), 0.5 * e0, 1.5 * e0, e0, name=g) for g, ids in groups.items())
    system = fp.AffineModel(model, params, solver="sparse")
    every = model.dofs  # (a property that builds the tuple: read once)
    labels = [every[i] for i in system.dofmap.free]
    assert len(labels) == 3 * (bays + 1) * storeys
    terms = []
    for i, g in enumerate(groups):
        theta = np.zeros(len(params))
        theta[i] = e0
        k = system.stiffness(theta[None])[0]
        k.eliminate_zeros()
        sp.save_npz(folder / f"{g}.npz", k)
        terms.append({"name": g, "file": f"{g}.npz", "lower": 0.5, "upper": 1.5})
    mass = sp.diags([1000.0 if d != "rz" else 0.0 for _, d in labels], format="csr")
    sp.save_npz(folder / "mass.npz", mass)
    path = folder / "frame.matrix.json"
    path.write_text(json.dumps({"format": "femu.matrix-model/1", "name": f"frame-{bays}x{storeys}-matrices",
                                "dofs": len(labels), "stiffness": terms,
                                "mass": [{"name": "lumped", "file": "mass.npz"}]}))
    return str(path)


def matrix_problem(n: int, folder):
    """(UpdatingProblem on the read matrix model, a point x) at size n, built once."""
    if n not in _CACHE:
        model = fp.load_matrix_model(export(n, folder))
        system = fp.MatrixSystem(model)
        rng = np.random.default_rng(n)
        truth = rng.uniform(0.95, 1.05, system.n_params)
        rows = np.linspace(0, model.n_dof - 1, 20).astype(int)
        lam, phi = system.eigen(truth[None], N_MODES, vectors=True, rows=rows)
        data = ModalData(str(model.source), tuple(int(r) + 1 for r in rows), frequencies_hz(lam[0]), phi[0])
        problem = fp.UpdatingProblem(model, data, n_model_modes=N_MODES, name=f"matrix{n}")
        _CACHE[n] = (problem, rng.uniform(0.97, 1.03, system.n_params))
    return _CACHE[n]


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("matrix-bench")


@pytest.mark.parametrize("n", list(SIZES))
@pytest.mark.benchmark(group="matrix")
def test_matrix_evaluate_one_point(benchmark, record, folder, n):
    problem, x = matrix_problem(n, folder)
    bays, storeys = SIZES[n]
    dofs = problem.system.n_free
    assert dofs == 3 * (bays + 1) * storeys and problem.system.n_massless == dofs // 3
    ours = frequencies_hz(problem.system.eigen(x[None], N_MODES)[0][0])
    if n <= 10000:  # scipy's own shift-invert: its LU, its start vector (a few seconds at 100,000)
        k, m = problem.system.stiffness(x[None])[0].tocsc(), problem.system.mass(x[None])[0].tocsc()
        ref = frequencies_hz(np.sort(eigsh(k, N_MODES, m, sigma=0.0, which="LM", return_eigenvectors=False)))
        np.testing.assert_allclose(ours, ref, rtol=1e-8)
    f = benchmark.pedantic(problem.evaluate, args=(x[None],), rounds=ROUNDS[n], warmup_rounds=1)
    assert f.shape == (1,) and np.isfinite(f[0])
    record(f"matrix_eval:{n}", 1, n_dof=dofs, n_params=problem.n_var, n_massless=problem.system.n_massless)


@pytest.mark.parametrize("n", list(SIZES))
@pytest.mark.benchmark(group="matrix")
def test_matrix_bare_cholesky_and_arpack_floor(benchmark, record, folder, n):
    cholmod = pytest.importorskip("sksparse.cholmod", reason="the floor is CHOLMOD's (the 'cholmod' extra)")
    problem, x = matrix_problem(n, folder)
    solver = problem.system._solver
    k, m = problem.system.stiffness(x[None])[0].tocsc(), problem.system.mass(x[None])[0].tocsc()
    a = (k - solver.sigma * m).tocsc()
    analysis = cholmod.analyze(a, mode=fe_problem.sparse.CHOLMOD_MODE)  # once per model, as the solver does
    v0 = np.random.default_rng(0).uniform(0.5, 1.5, a.shape[0])

    def floor():
        op = LinearOperator(a.shape, matvec=analysis.cholesky(a).solve_A, dtype=float)
        return eigsh(k, k=N_MODES, M=m, sigma=solver.sigma, which="LM", OPinv=op, v0=v0,
                     ncv=max(2 * N_MODES + 1, 20), tol=ARPACK_TOL, return_eigenvectors=False)

    lam = np.sort(benchmark.pedantic(floor, rounds=ROUNDS[n], warmup_rounds=1))
    ours = problem.system.eigen(x[None], N_MODES)[0][0]
    np.testing.assert_allclose(lam, ours, rtol=1e-10)  # the same answer: a floor of the same work
    record(f"matrix_floor:{n}", 1, n_dof=a.shape[0], recipe="CHOLMOD numeric factor (analysis kept) + eigsh shift-invert, "
           f"tol {ARPACK_TOL:g}, M singular")
