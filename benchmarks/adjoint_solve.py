"""The first-order screen's adjoint blocks (`screening._adjoint`) at the diagnosis benchmark's
3,024-DOF frame (`test_bench_diagnosis_scale.cracked_frame(3, 56)`, its calibrated coordinates
and paired modes): all blocks by CHOLMOD's L D L^T of the bordered matrix (all right-hand sides
at once, with the backward-error check of every column) against SuperLU's pivoted LU (one
column at a time), CPU time, best of 3 interleaved rounds, and their largest difference.

    OPENBLAS_NUM_THREADS=1 python benchmarks/adjoint_solve.py [n_free: 1080 or 3024]
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

sys.path.insert(0, str(Path(__file__).parent))
os.environ.setdefault("FEMU_SOLVER_WORKERS", "1")
from test_bench_diagnosis_scale import DIAGNOSIS_FRAMES, cracked_frame  # noqa: E402

import fe_problem as fp  # noqa: E402
from fe_problem.diagnosis import screening  # noqa: E402
from fe_problem.diagnosis.core import calibrate  # noqa: E402


def main(argv: list[str]) -> int:
    n = int(argv[1]) if len(argv) > 1 else 3024
    model, data = cracked_frame(*DIAGNOSIS_FRAMES[n], f"frame{n}")
    cal = calibrate(model, data, 0.002, 0.02)
    st = cal.setting
    system = st.system
    modes = np.unique(cal.base.pairing[cal.base.pairing >= 0])
    lam, phi = system.eigen(system.x0[None, :], st.n_modes, vectors=True)
    lam, phi = lam[0], phi[0]
    k0, m0 = sp.csc_matrix(system.k0), sp.csc_matrix(system.m0)
    rows = system.nodal_rows(st.coords)
    c_t = np.zeros((system.n_free, len(rows)))
    c_t[rows[rows >= 0], np.flatnonzero(rows >= 0)] = 1.0
    times = {True: [], False: []}
    out = {}
    for _ in range(3):
        for ldlt in (False, True):
            t = time.process_time()
            out[ldlt] = [screening._adjoint(k0, m0, lam[i], phi[:, i], c_t, ldlt) for i in modes]
            times[ldlt].append(time.process_time() - t)
    diff = max(np.abs(a - b).max() / np.abs(b).max() for a, b in zip(out[True], out[False]))
    lu, ld = min(times[False]), min(times[True])
    print(f"{system.n_free} free DOFs, {len(modes)} blocks of {len(rows)} coordinates: SuperLU {lu:.3f} s, "
          f"L D L^T {ld:.3f} s CPU ({lu / ld:.1f}x); largest difference {diff:.1e} of a block's largest entry")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
