"""How much the pinned-moduli fit of a large diagnosis depends on rounding (issue 25, docs/scale.md,
"Diagnosis at size"): the benchmark's 3,024-DOF frame with the crack of
benchmarks/test_bench_diagnosis_scale.py, the bounded linear fit of `screening.bounded_linear_fit`
run twice on the same compressed Jacobian: with numpy's dense products (as the diagnosis runs it)
and with BLAS's triangular products (the same numbers to about 4e-13 of the entries). Prints the
largest change of a fitted modulus (as z in [0, 1]) and how many moduli are pinned each way.

    OPENBLAS_NUM_THREADS=1 FEMU_SOLVER_WORKERS=1 python benchmarks/pinned_rounding.py
"""

from __future__ import annotations

import time

import numpy as np
from scipy.linalg import blas
from scipy.optimize import least_squares
from scipy.sparse.linalg import LinearOperator

from fe_problem.diagnosis import screening
from fe_problem.diagnosis.core import _pinned_moduli, calibrate
from test_bench_diagnosis_scale import cracked_frame


def triangular(r: np.ndarray) -> LinearOperator:
    """[R; 0] ((n + 1) x n, R upper triangular) with dtrmv products."""
    rf = np.asfortranarray(np.triu(r[:-1]))
    n = rf.shape[1]
    return LinearOperator((n + 1, n), dtype=float,
                          matvec=lambda x: np.append(blas.dtrmv(rf, np.ravel(x).astype(float)), 0.0),
                          rmatvec=lambda y: blas.dtrmv(rf, np.ravel(y)[:n].astype(float), trans=1),
                          matmat=lambda x: np.vstack([rf @ x, np.zeros((1, x.shape[1]))]))


def main() -> None:
    model, data = cracked_frame(3, 56, "frame3024")
    cal = calibrate(model, data, 0.002, 0.02)
    captured = {}
    fit = screening.bounded_linear_fit

    def grab(r0, jac, max_nfev=60):
        captured["problem"] = (r0, jac)
        return fit(r0, jac, max_nfev)

    screening.bounded_linear_fit = grab
    try:
        _pinned_moduli(cal)
    finally:
        screening.bounded_linear_fit = fit
    r0, jac = captured["problem"]
    c, r = screening.compressed(r0, jac)
    n = jac.shape[1]
    out = {}
    for name, op in (("dense products", r), ("triangular products", triangular(r))):
        t = time.process_time()
        z = least_squares(lambda z: c + op @ (z - 0.5), np.full(n, 0.5), jac=lambda z: op, bounds=(0.0, 1.0),
                          max_nfev=60, tr_solver="lsmr").x
        out[name] = z
        pinned = (z <= 0.005) | (z >= 0.995)
        print(f"{name}: {time.process_time() - t:.2f} s CPU, {int(pinned.sum())} of {n} moduli pinned")
    a, b = out.values()
    pa, pb = (a <= 0.005) | (a >= 0.995), (b <= 0.005) | (b >= 0.995)
    print(f"largest change of a fitted z: {np.abs(a - b).max():.3g}; pinned by one way only: {int((pa ^ pb).sum())}")


if __name__ == "__main__":
    main()
