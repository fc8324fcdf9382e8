"""Free DOFs without mass (fe_problem/solver.py's condensation, fe_problem/sparse.py's
shift-invert with a singular M, AffineModel's `massless`): the H-frame with lumped-mass beams
(every rotation massless, free-free: three rigid-body modes), with parameters.

The reference is a separately written static condensation (explicit inverses, scipy's
generalized eigh) of the same assembled K and M, and central differences for the
sensitivities; tests/test_import_nastran.py and tests/test_import_opensees.py check such models
against OpenSeesPy."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.linalg

import fe_problem as fp
from fe_problem.model import ModelFileError
from femu.cli import main

N_MODES = 6


def lumped_hframe():
    h = fp.load_model("hframe")
    return h.replace(elements=tuple(dataclasses.replace(e, formulation=e.formulation + "-lumped")
                                    for e in h.elements))


def parameters(model):
    ids = [e.id for e in model.elements]
    mat = model.elements[0].material
    rho = model.materials[mat].density_kg_m3
    e0 = model.element_modulus_pa(ids[0])
    return (fp.Parameter("modulus", tuple(ids[:4]), 0.5 * e0, 1.5 * e0, e0),
            fp.Parameter("modulus", tuple(ids[6:9]), 0.5 * e0, 1.5 * e0, e0),
            fp.Parameter("density", tuple(ids[4:8]), 0.5 * rho, 1.5 * rho, rho))


@pytest.fixture(scope="module")
def systems():
    model = lumped_hframe()
    pars = parameters(model)
    return {path: fp.AffineModel(model, pars, solver=path) for path in ("dense", "sparse")}


@pytest.fixture(scope="module")
def points(systems):
    s = systems["dense"]
    rng = np.random.default_rng(3)
    return np.vstack([s.x0, s.lower + (s.upper - s.lower) * rng.random((2, s.n_params))])


def condensed_reference(k, m, n_skip, n_modes):
    """Eigenpairs of K phi = lambda M phi with the DOFs whose M row is zero condensed out,
    written out plainly: K_aa - K_ab K_bb^-1 K_ba, scipy's eigh with M_aa, phi_b recovered."""
    b = np.flatnonzero(~np.abs(m).any(axis=1))
    a = np.flatnonzero(np.abs(m).any(axis=1))
    kbb_inv = np.linalg.inv(k[np.ix_(b, b)])
    kc = k[np.ix_(a, a)] - k[np.ix_(a, b)] @ kbb_inv @ k[np.ix_(b, a)]
    lam, phi_a = scipy.linalg.eigh(0.5 * (kc + kc.T), m[np.ix_(a, a)])
    phi = np.zeros((len(k), len(lam)))
    phi[a] = phi_a
    phi[b] = -kbb_inv @ k[np.ix_(b, a)] @ phi_a
    return lam[n_skip:n_skip + n_modes], phi[:, n_skip:n_skip + n_modes], len(b)


@pytest.mark.parametrize("path", ["dense", "sparse"])
def test_modes_equal_an_independent_condensation(systems, points, path):
    s = systems[path]
    assert s.massless.size == 13 and s.n_rigid == 3 and s.n_elastic == s.n_free - 13 - 3
    lam, phi = s.eigen(points, N_MODES, vectors=True)
    for i, theta in enumerate(points):
        k = np.asarray(systems["dense"].stiffness(theta[None, :])[0])
        m = np.asarray(systems["dense"].mass(theta[None, :])[0])
        ref_lam, ref_phi, n_b = condensed_reference(k, m, 3, N_MODES)
        assert n_b == 13
        np.testing.assert_allclose(lam[i], ref_lam, rtol=1e-10, atol=0)
        # the same shapes, massless rows included, mass-normalised (sign aside)
        sign = np.sign(np.einsum("im,im->m", phi[i], ref_phi))
        np.testing.assert_allclose(phi[i] * sign, ref_phi, rtol=0, atol=1e-7 * np.abs(ref_phi).max())
        np.testing.assert_allclose(np.einsum("im,ij,jm->m", phi[i], m, phi[i]), 1.0, rtol=1e-10)


@pytest.mark.parametrize("path", ["dense", "sparse"])
def test_sensitivities_equal_central_differences(systems, points, path):
    s = systems[path]
    lam, _, dlam = s.eigen_sensitivities(points[1:2], N_MODES)
    theta = points[1]
    for k in range(s.n_params):
        h = 1e-5 * (s.upper[k] - s.lower[k])
        up, down = theta.copy(), theta.copy()
        up[k] += h
        down[k] -= h
        fd = (s.eigen(up[None, :], N_MODES)[0][0] - s.eigen(down[None, :], N_MODES)[0][0]) / (2 * h)
        np.testing.assert_allclose(dlam[0, :, k], fd, rtol=1e-6, atol=1e-9 * np.abs(lam).max() / h)


def test_the_lumped_frame_differs_from_the_consistent_one(systems):
    """Not a consistent-mass solve in disguise: the massless rotations lower the frequencies."""
    consistent = fp.modal_analysis(fp.load_model("hframe"), N_MODES).frequencies_hz
    lumped = fp.modal_analysis(lumped_hframe(), N_MODES).frequencies_hz
    assert np.all(lumped < consistent * 0.99)


def test_a_massless_dof_nothing_holds_is_refused_in_one_line(tmp_path, capsys):
    """Both beams at node 2 pinned there: its rotation has neither mass nor stiffness."""
    model = lumped_hframe()
    at2 = [e for e in model.elements if 2 in (e.node_i, e.node_j)]
    assert len(at2) == 2
    elements = tuple(dataclasses.replace(e, release_i=0.0 if e.node_i == 2 else e.release_i,
                                         release_j=0.0 if e.node_j == 2 else e.release_j)
                     if e in at2 else e for e in model.elements)
    path = tmp_path / "hinged.model.json"
    fp.save_model(model.replace(elements=elements, name="hinged"), path)
    for solver in ("dense", "sparse"):
        assert main(["model", str(path), "--solver", solver]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and str(path) in err, err
        assert ": node 2 rz can move without mass and without straining anything" in err, err


def test_the_diagnosis_refuses_massless_dofs_by_name():
    model = lumped_hframe()
    data = fp.synthetic_measurement(model, 6, model_name=model.name)
    with pytest.raises(ModelFileError, match="13 DOF\\(s\\) carry no mass .* the diagnosis does not handle"):
        fp.diagnose(model, data)


@pytest.mark.parametrize("path, step, rtol", [("dense", 1e-4, 1e-6), ("sparse", 1e-3, 1e-5)])
def test_the_analytic_jacobian_with_massless_dofs_is_the_residuals_derivative(path, step, rtol):
    """certify's ModalJacobian (Nelson's bordered system, which stays nonsingular with a
    singular M for a simple eigenvalue) against central differences of the residuals, the shape
    rows on their own; the measured DOFs include massless rotations."""
    from fe_problem.certify import ModalJacobian

    model = lumped_hframe()
    pars = parameters(model)
    dofs = [(n.id, d) for n in model.nodes[::2] for d in ("x", "y", "rz")]
    data = fp.synthetic_measurement(model, 6, dofs=dofs, model_name=model.name, parameters=pars,
                                    theta=np.array([p.initial * 1.1 for p in pars]))
    p = fp.UpdatingProblem(model, data, pars, shape_weight=1.0, solver=path)
    assert p.system.path == path and p.system.massless.size == 13
    mj = ModalJacobian(p)
    x = np.random.default_rng(5).uniform(p.xl, p.xu)
    r, jac = mj(x)
    h = step * (p.xu - p.xl)
    e = np.diag(h)
    fd = ((mj.residuals(x + e) - mj.residuals(x - e)) / (2 * h[:, None])).T
    assert np.abs(jac - fd).max() <= rtol * np.abs(fd).max()
    assert np.abs(jac[6:] - fd[6:]).max() <= rtol * np.abs(fd[6:]).max()


def test_a_lumped_space_frame_equals_an_independent_condensation():
    """frame3d with lumped-mass beams (three massless rotations per free node) on both paths."""
    f = fp.load_model("frame3d")
    model = f.replace(elements=tuple(dataclasses.replace(e, formulation=e.formulation + "-lumped")
                                     for e in f.elements))
    dense, sparse = (fp.AffineModel(model, solver=path) for path in ("dense", "sparse"))
    assert dense.massless.size > 0 and np.array_equal(dense.massless, sparse.massless)
    k = dense.stiffness(np.zeros((1, 0)))[0]
    m = dense.mass(np.zeros((1, 0)))[0]
    ref_lam, _, n_b = condensed_reference(k, m, dense.n_rigid, N_MODES)
    assert n_b == dense.massless.size and dense.n_elastic == dense.n_free - n_b - dense.n_rigid
    for s in (dense, sparse):
        np.testing.assert_allclose(s.eigen(np.zeros((1, 0)), N_MODES)[0][0], ref_lam, rtol=1e-10, atol=0)
