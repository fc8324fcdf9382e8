"""Where a sandboxed run's time goes, per evaluation, against the same run in one process.

    OPENBLAS_NUM_THREADS=1 python benchmarks/sandbox_breakdown.py [ROUNDS]

For three optimizers on the H-frame (1,000 evaluations, seed 0) and for a null problem (an
objective that costs nothing, so that only the round trips are left), each mode in turn in each
round: wall and CPU microseconds per evaluation of the in-process run (`isolated=False`) and of
the sandboxed one, the sandboxed CPU split into the evaluating process's and the worker's, and
the FE evaluations' own CPU in both (`fe_cpu_s`). CPU seconds are what a loaded machine does
not stretch (wall seconds are); the difference between the modes' CPU is what the sandbox adds.
"outside ms": milliseconds of the adapters.run call outside the run's own wall_s (which starts
once the optimizer is loaded): in the sandbox its loading in the worker, the core's claim and
release, the worker's end and the next run's spare forked; in-process the optimizer's lookup and
the record. Prints the median over ROUNDS (default 3) and the load average.
"""

from __future__ import annotations

import os
import sys
import time

import fe_problem._threads  # noqa: F401  (one BLAS thread unless set: before numpy loads)
import numpy as np

from adapters import run
from adapters.sandbox import server_address
from adapters.variants import make_problem

BUDGET = 1000
PROBE = "sandbox_probe:OnePointPerCall"


class NullProblem:
    """The H-frame's bounds and an objective of 0 at no cost."""

    name = "null"

    def __init__(self):
        p = make_problem("paper")
        self.n_var, self.xl, self.xu, self.x0 = p.n_var, p.xl, p.xu, p.x0

    def evaluate(self, X):
        return np.zeros(len(np.atleast_2d(X)))


def one_run(name: str, make, isolated: bool) -> dict:
    """Per-evaluation microseconds of one run (its problem made before the clocks start)."""
    problem = make()
    cpu0, t0 = time.process_time(), time.perf_counter()
    r = run(name, problem, BUDGET, 0, isolated=isolated)
    wall, here = time.perf_counter() - t0, time.process_time() - cpu0
    assert r.status == "ok" and r.n_evals == BUDGET, (name, r.status, r.error)
    us = 1e6 / BUDGET
    # a sandboxed record's cpu_s is the evaluating process's CPU during the run plus the worker's
    return {"wall": wall * us, "cpu": r.cpu_s * us, "cpu_eval_side": here * us,
            "cpu_worker": max(r.cpu_s - here, 0.0) * us if isolated else 0.0, "fe_cpu": r.fe_cpu_s * us,
            "outside_ms": (wall - r.wall_s) * 1e3}


def main(rounds: int = 3) -> None:
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # sandbox_probe, for the worker too
    cases = [(PROBE, NullProblem), (PROBE, lambda: make_problem("paper")), ("scipy-sa", lambda: make_problem("paper")),
             ("pymoo-ga", lambda: make_problem("paper")), ("cma-es", lambda: make_problem("paper"))]
    server_address(["sandbox_probe", "adapters.scipy_sa", "adapters.pymoo_ga", "adapters.cma_es"])
    for name, make in cases:  # each optimizer's library imported in both modes before timing
        for isolated in (True, False):
            run(name, make(), 50, 0, isolated=isolated)
    figures: dict = {}
    for _ in range(rounds):
        for name, make in cases:
            for isolated in (True, False):
                key = (name, "null" if make is NullProblem else "hframe", isolated)
                for k, v in one_run(name, make, isolated).items():
                    figures.setdefault(key, {}).setdefault(k, []).append(v)
    print(f"load average at the end: {', '.join(f'{v:.2f}' for v in os.getloadavg())}; medians of {rounds} rounds, "
          f"microseconds per evaluation ({BUDGET} evaluations)")
    print(f"{'optimizer / problem':<32}{'mode':>9}{'wall':>8}{'CPU':>8}{'eval side':>10}{'worker':>8}{'FE CPU':>8}"
          f"{'+CPU':>7}{'wall x':>8}{'CPU x':>7}{'outside ms':>11}")
    for (name, problem, isolated), f in figures.items():
        m = {k: float(np.median(v)) for k, v in f.items()}
        base = {k: float(np.median(v)) for k, v in figures[(name, problem, False)].items()}
        extra = (f"{m['cpu'] - base['cpu']:>7.0f}{m['wall'] / base['wall']:>8.2f}{m['cpu'] / base['cpu']:>7.2f}"
                 if isolated else "")
        side = f"{m['cpu_eval_side']:>10.0f}{m['cpu_worker']:>8.0f}" if isolated else f"{'':>10}{'':>8}"
        print(f"{name.split(':')[-1] + ' / ' + problem:<32}{'sandbox' if isolated else 'inproc':>9}{m['wall']:>8.0f}"
              f"{m['cpu']:>8.0f}{side}{m['fe_cpu']:>8.0f}{extra:<22}{m['outside_ms']:>11.1f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
