"""ARPACK's tolerance and the factorisation, measured (issue 25): on the scale frames, per size,
the lowest 10 frequencies with SuperLU at tol=0 (the path before issue 25) against SuperLU and
CHOLMOD at tol=0 and at `fe_problem.sparse.ARPACK_TOL`: the largest relative change of a
frequency, the solves per point (ARPACK's operator applications) and the time per point (best of 3).

    OPENBLAS_NUM_THREADS=1 python benchmarks/arpack_tolerance.py 300 3000 9000
"""

from __future__ import annotations

import sys
import time

import numpy as np

import fe_problem.sparse as fs
from fe_problem.terms import Terms
from test_bench_scale import scale_problem


def main(sizes: list[int]) -> None:
    for n in sizes:
        model, problem, x = scale_problem(n)
        k, m = Terms(model, problem.system.parameters).free_arrays()
        ways = [("superlu", 0.0), ("superlu", fs.ARPACK_TOL)]
        if fs._cholmod is not None:
            ways += [("cholmod", 0.0), ("cholmod", fs.ARPACK_TOL)]
        ref = None
        for fac, tol in ways:
            s = fs.SparseModalSolver(k, m, problem.system.n_free, problem.system.x0, model.name, workers=1,
                                     factorization=fac, arpack_tol=tol)
            solves = [0]
            factor = s._factor

            def counted(a_data, factor=factor):
                solve = factor(a_data)

                def apply(b):
                    solves[0] += 1
                    return solve(b)
                return apply
            s._factor = counted
            best = float("inf")
            for _ in range(3):
                solves[0] = 0
                t = time.perf_counter()
                lam = s._modes(x, 10, False, None, False)[0]
                best = min(best, time.perf_counter() - t)
            hz = np.sqrt(lam)
            ref = hz if ref is None else ref
            print(f"{n:>6} DOFs  {fac:8} tol {tol:<6g} {best * 1e3:8.1f} ms  {solves[0]:3d} solves  "
                  f"max rel. change of a frequency {np.max(np.abs(hz / ref - 1)):.1e}", flush=True)


if __name__ == "__main__":
    main([int(a) for a in sys.argv[1:]] or [300, 3000, 9000])
