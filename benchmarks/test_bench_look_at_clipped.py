"""The cost of `core.look_at_clipped` in a space frame's screen and fit.

`core.screen_and_fit` on the shipped `frame3d` (sparse path) with a corner column's weak zone
about ry (element 1, 10 % of its bending stiffness over 0.2-0.3 of it; the truth built by our
own weak-zone element: a timing input, not a test of the diagnosis) and 12 modes at x, y, rx,
ry of every floor node with 0.1 % / 1 % noise, with the shortlist look (`LOOK_SHORTLIST` = 3)
and without it (0). Measured 2026-11-26, one run, 2 rounds each at load 4.6 (min): 9.37 s
without, 11.43 s with: 1.22x (the best fitted candidate: a joint of element 2, chi^2 522,
without; a zone about ry at 0.2 of element 3, the mirror of element 1, chi^2 422, with). Run:

    OPENBLAS_NUM_THREADS=1 python -m pytest benchmarks/test_bench_look_at_clipped.py --benchmark-only -q
"""

from __future__ import annotations

import pytest

import fe_problem as fp
from fe_problem.diagnosis import core, zones


@pytest.fixture(scope="module")
def calibration():
    model = fp.load_model("frame3d")
    model = model.replace(measured_dofs=tuple((n, d) for n, _ in model.measured_dofs[::2]
                                              for d in ("x", "y", "rx", "ry")))
    truth = zones.with_zone(model, 1, 0.2, 0.3, 0.1, "ry")
    data = fp.synthetic_measurement(truth, 12, freq_noise=0.001, shape_noise=0.01, seed=11, model_name="frame3d")
    return core.calibrate(model, data, core.DEFAULT_FREQ_NOISE, core.DEFAULT_SHAPE_NOISE)


def screen_and_fit(cal, shortlist: int):
    saved, core.LOOK_SHORTLIST = core.LOOK_SHORTLIST, shortlist
    try:
        return core.screen_and_fit(cal, None, core.N_FIT)
    finally:
        core.LOOK_SHORTLIST = saved


@pytest.mark.parametrize("shortlist", [0, 3], ids=["first-order only", "shortlist looked at"])
def test_screen_and_fit(benchmark, calibration, shortlist):
    benchmark.group = "frame3d screen and fit, corner-column zone"
    found = benchmark.pedantic(screen_and_fit, args=(calibration, shortlist), rounds=2, iterations=1)
    assert len(found.fitted) >= core.N_FIT
