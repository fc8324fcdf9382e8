"""The dense and the sparse path on the suite's space-frame problems (a script, not a benchmark).

    OPENBLAS_NUM_THREADS=1 python benchmarks/suite3d_paths.py

For frame3d-shape/12/1, 24/1 and 48/1 (216, 432, 864 free DOFs) the same problem is built with
`solver="dense"` and `solver="sparse"`; prints ms per point for 20 one-point calls and for one
call of 200 points, and the largest relative difference of the two paths' J on those points
(both also give J(truth) ~ 0). `solver="auto"` takes the sparse path at all three sizes
(`fe_problem.assembly.SPARSE_MIN_DOFS`); docs/suite.md quotes the ratios.
"""

from __future__ import annotations

import time

import numpy as np

import fe_problem as fp


def main() -> None:
    for pid in ("frame3d-shape/12/1", "frame3d-shape/24/1", "frame3d-shape/48/1"):
        suite = fp.suite_problem(pid)
        values = {}
        for solver in ("dense", "sparse"):
            p = fp.UpdatingProblem(suite.model, suite.data, parameters=suite.parameters, weights="unit",
                                   shape_weight=1.0, solver=solver)
            X = np.random.default_rng(0).uniform(p.xl, p.xu, (200, p.n_var))
            p.evaluate(X[:2])
            t = time.perf_counter()
            for k in range(20):
                p.evaluate(X[k])
            one_ms = (time.perf_counter() - t) / 20 * 1e3
            t = time.perf_counter()
            values[solver] = p.evaluate(X)
            batch_ms = (time.perf_counter() - t) / 200 * 1e3
            print(f"{pid} {solver:6s} one point {one_ms:7.1f} ms, 200 points {batch_ms:7.1f} ms/point "
                  f"J(truth) {p.evaluate(suite.truth)[0]:.1e}", flush=True)
        diff = np.max(np.abs(values["dense"] - values["sparse"]) / values["sparse"])
        print(f"{pid} largest relative difference of J between the paths: {diff:.1e}")


if __name__ == "__main__":
    main()
