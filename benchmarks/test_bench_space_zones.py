"""The weak-zone terms of a space frame's diagnosis: every zone of the grid in one batch against
one call per zone.

`LocalMatrices._space_zone_grid` (fe_problem/diagnosis/local.py) builds the screening term of
every weak-zone candidate of a space frame (each element, each of its places, each bending
plane) through one call of the formulation's vectorised `zone_stiffness`; the alternative is
`zones.zone_stiffness` called once per zone (what `LocalMatrices.zone` does for a place off the
grid). Both give the same terms (checked before timing). The frame: `regular_frame_3d(3, 3, 6)`
(240 elements, 3,360 zones). Measured 2026-11-26, one run at load 4.7 (median): batched 77 ms,
one call per zone 2,100 ms, 27x. Run:

    OPENBLAS_NUM_THREADS=1 python -m pytest benchmarks/test_bench_space_zones.py --benchmark-only -q
"""

from __future__ import annotations

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.diagnosis import zones
from fe_problem.diagnosis.local import SPACE_ZONE_CHORD, LocalMatrices


@pytest.fixture(scope="module")
def frame():
    return fp.regular_frame_3d(3, 3, 6)


def batched(model):
    return LocalMatrices(model)._space_zone_grid


def per_zone(model):
    out = {}
    for e in model.elements:
        for about in zones.bending_rotations(model):
            for start, end in zones.zone_places(model, e.id, about):
                pair = zones.zone_stiffness(model, e.id, start, end, np.array([1.0, 1.0 - SPACE_ZONE_CHORD]), about)
                out[(e.id, start, end, about)] = (pair[1] - pair[0]) / SPACE_ZONE_CHORD
    return out


def test_batched(benchmark, frame):
    grid, one = batched(frame), per_zone(frame)
    assert grid.keys() == one.keys() and len(grid) > 3000
    scale = max(np.abs(v).max() for v in one.values())
    assert all(np.allclose(grid[k], one[k], rtol=1e-12, atol=1e-12 * scale) for k in grid)
    benchmark.group = "space weak-zone terms, 240 elements"
    benchmark.pedantic(batched, args=(frame,), rounds=5, iterations=1)


def test_per_zone(benchmark, frame):
    benchmark.group = "space weak-zone terms, 240 elements"
    benchmark.pedantic(per_zone, args=(frame,), rounds=2, iterations=1)
