"""What ending a sandboxed run's worker costs: milliseconds of `_Worker.end` per run.

    OPENBLAS_NUM_THREADS=1 python benchmarks/sandbox_end.py [RUNS]

Runs random-search (20 evaluations on the paper H-frame) RUNS times (default 40) through
adapters.run and times each run's `_Worker.end` (its worker started no process: the common
case); prints the median and quartiles in milliseconds and the load average. To compare two
codes, run it with each one's checkout first on PYTHONPATH, one after the other.
"""

from __future__ import annotations

import os
import statistics
import sys
import time

import fe_problem._threads  # noqa: F401  (one BLAS thread unless set: before numpy loads)

import adapters
from adapters import sandbox
from adapters.variants import make_problem


def main(runs: int) -> None:
    times: list[float] = []
    end = sandbox._Worker.end

    def timed(worker) -> None:
        t0 = time.perf_counter()
        end(worker)
        times.append(time.perf_counter() - t0)

    sandbox._Worker.end = timed
    for seed in range(runs):
        adapters.run("random-search", make_problem("paper"), 20, seed)
    q1, median, q3 = statistics.quantiles([1e3 * t for t in times], n=4)
    print(f"worker end, ms: median {median:.2f}, quartiles {q1:.2f}-{q3:.2f} ({len(times)} ends; "
          f"load {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 40)
