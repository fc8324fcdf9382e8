"""What splitting a batch over worker processes costs and gives on the sparse path: per point,
the wall time and this process's own CPU time of a batch of 8 points (10 modes) with 1 and 2
processes, on frames of 300, 600 and 1,050 DOFs (one modulus per element).

    OPENBLAS_NUM_THREADS=1 python benchmarks/parallel_split.py

On an idle 2-core machine the wall time halves with the CPU time; on a machine shared with
other work only this process's CPU time shows the split (the wall time is what the scheduler
gives). `fe_problem.sparse.PARALLEL_MIN_DOFS` is set from it.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import fe_problem._threads  # noqa: F401,E402
import numpy as np  # noqa: E402

import fe_problem as fp  # noqa: E402
from scale_frames import regular_frame  # noqa: E402


def main() -> None:
    for bays, storeys in ((9, 10), (9, 20), (9, 35)):
        model = regular_frame(bays, storeys)
        pars = fp.element_moduli(model, lower=1.8e11, upper=2.4e11)
        system = fp.AffineModel(model, pars, solver="sparse")
        X = np.random.default_rng(0).uniform(1.9e11, 2.3e11, (8, len(pars)))
        row = []
        for workers in (1, 2):
            system.workers = workers
            system.eigen(X[:2], 10)
            best = (np.inf, np.inf)
            for _ in range(5):
                t0, c0 = time.perf_counter(), time.process_time()
                system.eigen(X, 10)
                best = min(best, (time.perf_counter() - t0, time.process_time() - c0))
            row.append(f"{workers} process(es): wall {best[0] / 8 * 1e3:.2f} ms, own CPU {best[1] / 8 * 1e3:.2f} ms")
        print(f"{system.n_free:>6} DOFs  " + " | ".join(row))


if __name__ == "__main__":
    main()
