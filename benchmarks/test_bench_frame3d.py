"""The space frame element matrices: vectorised over all elements against one call per element.

`element_matrices` of a 5 x 5-bay, 46-storey space frame (4,416 elements, 10,152 DOFs) in one
call (the formulations' (n, 12, 12) kernels, fe_problem/elements/beam3d.py), against the same
kernels called once per element in a Python loop (what a per-element implementation costs).
Both give the same matrices (checked before timing). Run:

    OPENBLAS_NUM_THREADS=1 python -m pytest benchmarks/test_bench_frame3d.py --benchmark-only -q
"""

from __future__ import annotations

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.elements import element_matrices, formulation


@pytest.fixture(scope="module")
def frame():
    return fp.regular_frame_3d(5, 5, 46)


def per_element(model):
    form = formulation("euler-bernoulli", model.layout)
    k = np.stack([form.stiffness(model, [e])[0] for e in model.elements])
    m = np.stack([form.mass(model, [e])[0] for e in model.elements])
    return k, m


def test_vectorised(benchmark, frame):
    k, m = element_matrices(frame)
    k1, m1 = per_element(frame)
    np.testing.assert_allclose(k, k1, rtol=1e-12, atol=1e-12 * np.abs(k).max())
    np.testing.assert_allclose(m, m1, rtol=1e-12, atol=1e-12 * np.abs(m).max())
    benchmark.group = "frame3d element matrices, 4,416 elements"
    benchmark.pedantic(element_matrices, args=(frame,), rounds=5, iterations=1)


def test_per_element(benchmark, frame):
    benchmark.group = "frame3d element matrices, 4,416 elements"
    benchmark.pedantic(per_element, args=(frame,), rounds=2, iterations=1)
