"""What a fresh worker costs an optimizer: its first run in a process forked from a process
like the sandbox's worker server, against a second run in that same process.

    OPENBLAS_NUM_THREADS=1 python benchmarks/sandbox_fresh_worker.py [FORKS]

This process imports what the server imports (numpy, the plugin layer, the three optimizers'
adapters; fe_problem and femu refused), then forks FORKS times (default 5); each child runs
the optimizer twice on the same cheap objective (a quadratic in the H-frame's 6-parameter
box, 1,000 evaluations, seed 0) and reports, for each run, the milliseconds from minimize's
start to its first objective call, the whole run's milliseconds and CPU milliseconds, and the
minor page faults (copy-on-write of the server's memory). The sandbox forks a fresh worker for
every run (adapters.sandbox), so every sandboxed run is a first run; an in-process run in a
long-lived process is a second one. Prints medians over the forks and the load average.
"""

from __future__ import annotations

import json
import os
import resource
import sys
import time

from adapters.sandbox_worker import _Refused

sys.meta_path.insert(0, _Refused())  # as in the server: the FE package and the application refused

import numpy as np  # noqa: E402

import adapters.harness  # noqa: E402,F401
from adapters.registry import get, module_of  # noqa: E402

NAMES = ("scipy-sa", "pymoo-ga", "cma-es")
BUDGET = 1000
XL, XU = np.full(6, 1e10), np.full(6, 3e10)  # the H-frame's moduli box (Pa), as in variant paper


class _Done(Exception):
    pass


class _Objective:
    """A quadratic in the box, with the time of its first call; stops the run at BUDGET points."""

    def __init__(self):
        self.n, self.first = 0, None

    def __call__(self, X):
        if self.first is None:
            self.first = time.perf_counter()
        X = np.atleast_2d(X)
        self.n += len(X)
        if self.n > BUDGET:
            raise _Done
        return (((X - XL) / (XU - XL) - 0.3) ** 2).sum(axis=1)


def _one(name: str) -> list[float]:
    """[ms to the first call, ms of the run, CPU ms of the run, minor faults] of one run."""
    objective = _Objective()
    faults0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        get(name)().minimize(objective, (XL.copy(), XU.copy()), BUDGET, np.random.default_rng(0))
    except _Done:
        pass
    t1, c1 = time.perf_counter(), time.process_time()
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - faults0
    return [(objective.first - t0) * 1e3, (t1 - t0) * 1e3, (c1 - c0) * 1e3, float(faults)]


def _in_a_fork(name: str) -> list[list[float]]:
    """The first and the second run of `name` in a child forked from this process."""
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(read)
        os.write(write, json.dumps([_one(name), _one(name)]).encode())
        os._exit(0)
    os.close(write)
    with os.fdopen(read) as fh:
        out = json.loads(fh.read())
    os.waitpid(pid, 0)
    return out


def main(forks: int = 5) -> None:
    for name in NAMES:
        __import__(module_of(name))
    print(f"medians over {forks} forks; per run: ms to the first objective call, ms of the run, CPU ms, minor faults")
    for name in NAMES:
        runs = np.array([_in_a_fork(name) for _ in range(forks)])  # (forks, 2 runs, 4 figures)
        first, second = np.median(runs[:, 0], axis=0), np.median(runs[:, 1], axis=0)
        print(f"{name:<10} first run in a fresh fork: {first[0]:6.1f} {first[1]:7.1f} {first[2]:7.1f} {first[3]:6.0f}"
              f"   second run: {second[0]:6.1f} {second[1]:7.1f} {second[2]:7.1f} {second[3]:6.0f}")
    print(f"load average at the end: {', '.join(f'{v:.2f}' for v in os.getloadavg())}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 5)
