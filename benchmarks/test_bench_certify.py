"""The cost of one Jacobian in the reference solve that certifies the suite's f_opt
(fe_problem/certify.py): the analytic one (`ModalJacobian`: one eigen-solve, eigenvalue
derivatives, Nelson's shape derivatives through adjoint solves) against the central difference
the first certificates used (2 n_var eigen-solves in one batch), on hframe-shape-noisy at 48
parameters (the dense path) and 192 (the sparse path). conftest.py puts the ratios side by
side; no test asserts on a time. Each benchmark checks that both give the same Jacobian, so a
fast path that computes something else cannot look good here.
"""

from __future__ import annotations

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.certify import ModalJacobian

GROUP = "certify-jacobian"


def _central(mj: ModalJacobian, x: np.ndarray, step_unit: float = 1e-3) -> np.ndarray:
    p = mj.problem
    h = step_unit * (p.xu - p.xl)
    r = mj.residuals(np.vstack([x + np.diag(h), x - np.diag(h)]))
    n = p.n_var
    return ((r[:n] - r[n:]) / (2 * h[:, None])).T


@pytest.fixture(scope="module", params=[48, 192])
def case(request):
    p = fp.suite_problem(f"hframe-shape-noisy/{request.param}/1")
    mj = ModalJacobian(p)
    x = np.random.default_rng(0).uniform(p.xl, p.xu)
    return request.param, mj, x


@pytest.mark.benchmark(group=GROUP)
def test_jacobian_analytic(benchmark, record, case):
    n, mj, x = case
    r, jac = benchmark.pedantic(mj, args=(x,), rounds=5, iterations=1)
    record(f"certify_jac_analytic:{n}", 1, n_var=n)
    fd = _central(mj, x)
    assert np.abs(jac - fd).max() <= 1e-5 * np.abs(fd).max()


@pytest.mark.benchmark(group=GROUP)
def test_jacobian_central_difference(benchmark, record, case):
    n, mj, x = case
    fd = benchmark.pedantic(_central, args=(mj, x), rounds=2 if n > 100 else 3, iterations=1)
    record(f"certify_jac_fd:{n}", 1, n_var=n)
    assert np.abs(mj(x)[1] - fd).max() <= 1e-5 * np.abs(fd).max()
