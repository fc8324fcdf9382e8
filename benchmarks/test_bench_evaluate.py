"""The cost of one FE evaluation: the batched objective against its two yardsticks.

All five benchmarks take the same N_POINTS (2000) fixed points, so the session summary can
put their per-sample times side by side (group "2000-points"):

- evaluate_paper: UpdatingProblem.evaluate on the paper's problem (eigenvalues only);
- evaluate_synthetic: the synthetic variant (8 modes, eigenvectors for the MAC term);
- loop_paper: the naive per-sample baseline (reference_fe.py: Python assembly and one
  scipy.linalg.eigh per sample), run on all 2000 points, not extrapolated;
- eigvalsh_bare / eigh_bare: numpy's batched eigensolver alone on 2000 stacked 39x39
  symmetric matrices, the floor for a problem of this size.

The ratios and their goals (>= 30x over the loop, >= 0.5x of the bare solver's speed) are
computed in conftest.py from this one session; no test asserts on a time. The loop
benchmark asserts that it computes the same objective values as evaluate, so a fast path
that computes something else cannot look good here.

Also here: fe_problem.modal_analysis on the shipped H-frame, the front door for one model
(group "modal-analysis"), which includes reading the model file and building the matrices.
"""

from __future__ import annotations

import numpy as np
import pytest

from adapters.variants import make_problem
from fe_problem import modal_analysis
from reference_fe import ReferenceObjective

GROUP = "2000-points"
#: Rounds of the fast benchmarks (each ~0.1-0.3 s); the minimum over them is what counts.
FAST_ROUNDS = 15
#: Rounds of the per-sample loop over all 2000 points (each ~1-3 s on the shared 2-core machine).
LOOP_ROUNDS = 3


@pytest.mark.benchmark(group=GROUP)
def test_evaluate_paper(benchmark, record, points):
    problem = make_problem("paper")
    f = benchmark.pedantic(problem.evaluate, args=(points,), rounds=FAST_ROUNDS, warmup_rounds=1)
    assert f.shape == (len(points),) and np.all(np.isfinite(f)) and np.all(f >= 0)
    record("evaluate_paper", len(points), variant="paper")


@pytest.mark.benchmark(group=GROUP)
def test_evaluate_synthetic_with_shapes(benchmark, record, points):
    problem = make_problem("synthetic")
    assert problem.shape_weight > 0, "the synthetic variant is the one that needs eigenvectors"
    f = benchmark.pedantic(problem.evaluate, args=(points,), rounds=FAST_ROUNDS, warmup_rounds=1)
    assert f.shape == (len(points),) and np.all(np.isfinite(f)) and np.all(f >= 0)
    record("evaluate_synthetic", len(points), variant="synthetic")


@pytest.mark.benchmark(group=GROUP)
def test_per_sample_loop_reference(benchmark, record, points):
    reference = ReferenceObjective()
    f = benchmark.pedantic(reference.evaluate, args=(points,), rounds=LOOP_ROUNDS)
    # Same objective as the fast path, or the comparison would mean nothing.
    np.testing.assert_allclose(f, make_problem("paper").evaluate(points), rtol=1e-9)
    record("loop_paper", len(points), variant="paper", method="per-sample Python assembly + scipy.linalg.eigh")


@pytest.mark.benchmark(group=GROUP)
def test_bare_batched_eigvalsh(benchmark, record, symmetric_stack):
    n, n_dof, _ = symmetric_stack.shape
    lam = benchmark.pedantic(np.linalg.eigvalsh, args=(symmetric_stack,), rounds=FAST_ROUNDS, warmup_rounds=1)
    assert lam.shape == (n, n_dof)
    record("eigvalsh_bare", n, matrix=f"{n_dof}x{n_dof}")


@pytest.mark.benchmark(group=GROUP)
def test_bare_batched_eigh(benchmark, record, symmetric_stack):
    n, n_dof, _ = symmetric_stack.shape
    lam, vec = benchmark.pedantic(np.linalg.eigh, args=(symmetric_stack,), rounds=FAST_ROUNDS, warmup_rounds=1)
    assert lam.shape == (n, n_dof) and vec.shape == (n, n_dof, n_dof)
    record("eigh_bare", n, matrix=f"{n_dof}x{n_dof}")


#: hframe.md's nominal elastic frequencies (Hz), modes 1-10, given to three decimals.
NOMINAL_HZ = [56.287, 127.217, 228.388, 263.523, 452.854, 658.509, 1043.033, 1248.947, 1442.207, 1813.389]


@pytest.mark.benchmark(group="modal-analysis")
def test_modal_analysis_single_model(benchmark, record):
    # The front door for one model: reads the shipped model file, builds the matrices, solves.
    result = benchmark(modal_analysis, "hframe", 10)
    np.testing.assert_allclose(result.frequencies_hz, NOMINAL_HZ, atol=1.5e-3)
    record("modal_analysis:hframe", 1, n_modes=10)
