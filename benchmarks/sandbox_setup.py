"""Per-run set-up of every built-in optimizer in the sandbox (issue 39: under 100 ms each).

    OPENBLAS_NUM_THREADS=1 python benchmarks/sandbox_setup.py [ROUNDS]

For each built-in on the H-frame (its minimum budget, seed 0): the milliseconds from the run's
spec sent to its worker until the optimizer is loaded and ready (`adapters.sandbox._load`: the
worker already confined, forked from the server before the run), median and max over ROUNDS
runs (default 3) after a first one (the first run of a built-in in a process has its server
import its library once: `sandbox_worker._preload_asked`). Also whether every run's record says
its worker was confined (`sandbox.is_confined`), and the load average.
"""

from __future__ import annotations

import os
import statistics
import sys
import time

import adapters
import adapters.sandbox as sandbox
from adapters.registry import BUILTINS
from adapters.variants import make_problem


def main(rounds: int = 3) -> None:
    times: dict[str, list[float]] = {}
    load = sandbox._load

    def timed(worker, name, spec):
        t0 = time.perf_counter()
        try:
            return load(worker, name, spec)
        finally:
            times.setdefault(name, []).append(time.perf_counter() - t0)

    sandbox._load = timed
    n_var = make_problem("paper").n_var
    print(f"load average {os.getloadavg()[0]:.1f}")
    for name in BUILTINS:
        need = sandbox.optimizer_facts(name, [n_var])["min_budget"][n_var]
        confined = True
        for _ in range(rounds + 1):
            r = adapters.run(name, make_problem("paper"), max(need, 1), 0)
            confined &= sandbox.is_confined(r.sandbox)
        t = [1000 * s for s in times[name][1:]]
        print(f"{name:18s} set-up ms: median {statistics.median(t):6.1f}  max {max(t):6.1f}  confined {confined}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
