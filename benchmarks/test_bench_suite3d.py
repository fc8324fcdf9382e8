"""The cost of the suite's space-frame families (`frame3d-freq`, `frame3d-shape`) beside a planar one.

- one `evaluate()` of one point (the per-call cost an optimizer that asks one point at a time
  pays) on frame3d-freq/12/1 and frame3d-shape/12/1 (216 free DOFs), frame3d-shape/48/1 (864)
  and the planar hframe-shape/12/1 (39) for scale;
- one `evaluate()` of a population of 1,000 points on frame3d-shape/12/1 (the batched path);
- a whole 1,000-evaluation run of `cma-es` on frame3d-shape/12/1 through the harness (in
  process: the sandbox's start-up is measured in test_bench_sandbox.py), which checks the run
  spent exactly 1,000 evaluations.

All 3-D sizes are above `SPARSE_MIN_DOFS`, so `solver="auto"` takes the sparse path, the one
the suite runs. No test asserts on a time. Run:

    OPENBLAS_NUM_THREADS=1 python -m pytest benchmarks/test_bench_suite3d.py --benchmark-only -q
"""

from __future__ import annotations

import numpy as np
import pytest

import fe_problem as fp
from adapters.harness import run

ONE_POINT = ("frame3d-freq/12/1", "frame3d-shape/12/1", "frame3d-shape/48/1", "hframe-shape/12/1")


@pytest.mark.parametrize("pid", ONE_POINT)
def test_evaluate_one_point(benchmark, pid):
    p = fp.suite_problem(pid)
    x = np.random.default_rng(0).uniform(p.xl, p.xu)
    p.evaluate(x)  # warm: the first call factorises what later calls reuse
    benchmark.group = "suite evaluate(), one point"
    j = benchmark.pedantic(p.evaluate, args=(x,), rounds=20, iterations=1)
    assert j.shape == (1,) and j[0] > 0


def test_evaluate_population_of_1000(benchmark):
    p = fp.suite_problem("frame3d-shape/12/1")
    X = np.random.default_rng(0).uniform(p.xl, p.xu, (1000, p.n_var))
    benchmark.group = "frame3d-shape/12/1, 1,000 evaluations"
    j = benchmark.pedantic(p.evaluate, args=(X,), rounds=1, iterations=1)
    assert j.shape == (1000,) and np.all(j > 0)


def test_cma_es_run_of_1000(benchmark):
    def once():
        return run("cma-es", fp.suite_problem("frame3d-shape/12/1"), budget=1000, seed=0, isolated=False)

    benchmark.group = "frame3d-shape/12/1, 1,000 evaluations"
    r = benchmark.pedantic(once, rounds=1, iterations=1)
    assert r.status == "ok" and r.n_evals == 1000 and r.best_f < r.trace[0][1]
