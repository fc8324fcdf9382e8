"""Where the sparse path overtakes the dense batched one: per-point time of
`AffineModel.eigen` (10 modes, eigenvalues only and with shapes) on both paths, for regular
frames of growing size with one modulus parameter per element.

    OPENBLAS_NUM_THREADS=1 python benchmarks/crossover.py

prints one row per size; `fe_problem.assembly.SPARSE_MIN_DOFS` is set from it. Timed with one
worker on the sparse path (a batch on two cores halves its time again)."""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import fe_problem._threads  # noqa: F401,E402
import numpy as np  # noqa: E402

import fe_problem as fp  # noqa: E402
from scale_frames import regular_frame  # noqa: E402

FRAMES = [(2, 4), (3, 5), (4, 6), (5, 7), (6, 8), (7, 9), (9, 10), (10, 13)]
N_POINTS = 40


def per_point(system, theta, vectors: bool) -> float:
    """Least time per point (s) over 3 repeats of one batch."""
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        system.eigen(theta, 10, vectors)
        best = min(best, time.perf_counter() - t0)
    return best / len(theta)


def main() -> None:
    print(f"{'bays x storeys':>15}{'free DOFs':>10}{'dense':>10}{'sparse':>10}{'dense+vec':>11}{'sparse+vec':>11}  (ms per point)")
    for bays, storeys in FRAMES:
        model = regular_frame(bays, storeys)
        pars = fp.element_moduli(model, lower=0.8 * 2.1e11, upper=1.2 * 2.1e11)
        theta = np.random.default_rng(0).uniform(0.8 * 2.1e11, 1.2 * 2.1e11, (N_POINTS, len(pars)))
        dense = fp.AffineModel(model, pars, solver="dense")
        sparse = fp.AffineModel(model, pars, solver="sparse", workers=1)
        t = [per_point(s, theta, v) * 1e3 for v in (False, True) for s in (dense, sparse)]
        print(f"{bays:>8} x {storeys:<4}{dense.n_free:>10}{t[0]:>10.2f}{t[1]:>10.2f}{t[2]:>11.2f}{t[3]:>11.2f}")


if __name__ == "__main__":
    main()
