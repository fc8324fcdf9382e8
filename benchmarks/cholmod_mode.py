"""CHOLMOD's factorisation modes and orderings on the scale frames: one numeric factorisation of
K - sigma M on a kept analysis, and 41 solves (ARPACK's count for 10 modes at 9,000 DOFs), CPU
time, best of 5, with the factor's stored entries (issue 25: why `fe_problem.sparse.CHOLMOD_MODE`
is "simplicial").

    OPENBLAS_NUM_THREADS=1 python benchmarks/cholmod_mode.py 9000 auto,simplicial default,nesdis

arguments: a size of scale_frames.SIZES, the modes ("auto", "supernodal", "simplicial") and the
orderings ("default", "amd", "metis", "nesdis", "best", "natural"), comma-separated.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from test_bench_scale import scale_problem  # noqa: E402


def main(argv: list[str]) -> int:
    if len(argv) != 4:
        print(__doc__)
        return 2
    from sksparse import cholmod

    n = int(argv[1])
    _, problem, x = scale_problem(n)
    solver = problem.system._solver
    k, m = problem.system.stiffness(x[None])[0].tocsc(), problem.system.mass(x[None])[0].tocsc()
    a = (k - solver.sigma * m).tocsc()
    b = np.random.default_rng(0).random(n)
    for mode in argv[2].split(","):
        for order in argv[3].split(","):
            analysis = cholmod.analyze(a, mode=mode, ordering_method=order)
            times = []
            for _ in range(5):
                t = time.process_time()
                f = analysis.cholesky(a)
                t1 = time.process_time()
                for _ in range(41):
                    f.solve_A(b)
                times.append((t1 - t, time.process_time() - t1))
            best = np.array(times).min(axis=0) * 1e3
            print(f"{mode:10s} {order:8s} factor entries {f.L().nnz:9d}  factor {best[0]:7.1f} ms  "
                  f"41 solves {best[1]:7.1f} ms", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
