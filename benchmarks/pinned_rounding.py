"""How much the pinned-moduli fit of a large diagnosis depends on rounding (issues 25 and 19,
docs/scale.md, "Diagnosis at size"): the benchmark's frame with the crack of
benchmarks/test_bench_diagnosis_scale.py (3,024 DOFs, or 1,080 with `1080` as argument), the
fit's data (r0, Jacobian) taken from the diagnosis, and each fit run on the Jacobian and on the
Jacobian times (1 + eps N(0, 1)) for eps = 1e-15 and 1e-12 (three draws each):
- `screening.bounded_linear_fit`, the MAP with each modulus' box as a Gaussian prior (strictly
  convex: unique and continuous in its data);
- the unregularised fit it replaced (`least_squares` trf/LSMR on the compressed problem from
  z = 1/2, at most 60 evaluations), which stopped where rounding left it.
Prints each fit's CPU time, the moduli it pins and, per draw, the largest change of a fitted
z in [0, 1] and how many moduli are pinned by one run only.

    OPENBLAS_NUM_THREADS=1 FEMU_SOLVER_WORKERS=1 python benchmarks/pinned_rounding.py [1080]
"""

from __future__ import annotations

import sys
import time

import numpy as np
from scipy.optimize import least_squares

from fe_problem.diagnosis import screening
from fe_problem.diagnosis.core import _pinned_moduli, calibrate
from test_bench_diagnosis_scale import cracked_frame


def unregularised(r0: np.ndarray, jac: np.ndarray) -> np.ndarray:
    """The fit `bounded_linear_fit` replaced: no prior, trf from the box's middle, 60 evaluations."""
    n = jac.shape[1]
    c, r = screening.compressed(r0, jac)
    return least_squares(lambda z: c + r @ (z - 0.5), np.full(n, 0.5), jac=lambda z: r, bounds=(0.0, 1.0),
                         max_nfev=60, tr_solver="lsmr").x


def pinned(z: np.ndarray) -> np.ndarray:
    """The diagnosis's rule (core._pinned_moduli): within 0.005 of a bound in z."""
    return (z <= 0.005) | (z >= 0.995)


def main() -> None:
    storeys = 20 if sys.argv[1:] == ["1080"] else 56
    model, data = cracked_frame(3, storeys, f"frame{storeys}")
    cal = calibrate(model, data, 0.002, 0.02)
    captured = {}
    fit = screening.bounded_linear_fit
    screening.bounded_linear_fit = lambda r0, jac: captured.update(problem=(r0, jac)) or fit(r0, jac)
    try:
        _pinned_moduli(cal)
    finally:
        screening.bounded_linear_fit = fit
    r0, jac = captured["problem"]
    ids = np.array(cal.setting.model.element_ids)
    print(f"{len(cal.setting.local.dofmap.free)} DOFs, {jac.shape[1]} moduli, {jac.shape[0]} residuals; "
          "the crack is in element 40")
    for name, method in (("MAP (bounded_linear_fit)", fit), ("unregularised (replaced)", unregularised)):
        t = time.process_time()
        z = method(r0, jac)
        print(f"{name}: {time.process_time() - t:.2f} s CPU; pinned elements {ids[pinned(z)].tolist()}")
        for eps in (1e-15, 1e-12):
            for seed in range(3):
                zp = method(r0, jac * (1 + eps * np.random.default_rng(seed).standard_normal(jac.shape)))
                print(f"  Jacobian x (1 + {eps:.0e} N): largest change of z {np.abs(zp - z).max():.2g}, "
                      f"pinned by one run only {int((pinned(zp) ^ pinned(z)).sum())}")


if __name__ == "__main__":
    main()
