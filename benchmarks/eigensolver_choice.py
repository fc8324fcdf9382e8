"""Why the sparse path runs shift-invert Lanczos (ARPACK) and not LOBPCG: per-point time of
both on the scale frames (test_bench_scale.py), the same factorisation of K - sigma M in each
(as ARPACK's shift-invert operator, as LOBPCG's preconditioner), LOBPCG warm-started from the
modes at the initial parameters (a fixed start, so a point stays independent of its batch).

    OPENBLAS_NUM_THREADS=1 python benchmarks/eigensolver_choice.py
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import fe_problem._threads  # noqa: F401,E402
import numpy as np  # noqa: E402
from scipy.sparse.linalg import LinearOperator, lobpcg  # noqa: E402

from test_bench_scale import scale_problem  # noqa: E402


def main() -> None:
    print(f"{'free DOFs':>10}{'ARPACK':>12}{'LOBPCG':>12}  max rel. diff of the 10 eigenvalues")
    for n in (300, 3000, 9000):
        _, problem, x = scale_problem(n)
        s = problem.system._solver
        _, start = s._point(problem.x0, 10, True)

        def arpack():
            return s._point(x, 10, False)[0]

        def warm_lobpcg():
            kd, md = s.k_data(x), s.m_data(x)
            solve = s._factor(kd - s.sigma * md)
            t = LinearOperator((s.n_free,) * 2, matvec=solve, dtype=float,
                               matmat=lambda b: np.column_stack([solve(c) for c in b.T]))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                lam, _ = lobpcg(s.matrix(kd), start.copy(), B=s.matrix(md), M=t, tol=1e-9, maxiter=50, largest=False)
            return np.sort(lam)

        times = {}
        for name, f in (("arpack", arpack), ("lobpcg", warm_lobpcg)):
            best = np.inf
            for _ in range(3):
                t0 = time.perf_counter()
                lam = f()
                best = min(best, time.perf_counter() - t0)
            times[name] = best
        diff = np.max(np.abs(warm_lobpcg() / arpack() - 1))
        print(f"{n:>10}{times['arpack'] * 1e3:>10.1f}ms{times['lobpcg'] * 1e3:>10.1f}ms  {diff:.1e}")


if __name__ == "__main__":
    main()
