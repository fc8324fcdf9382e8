"""What the sandbox costs: a 1,000-evaluation run on the H-frame (variant paper) with its
optimizer in a worker process (adapters.run, the default) against the same run in the
problem's own process (adapters.run(..., isolated=False), the debugging mode; before the
sandbox every run was so).

One optimizer that asks for one point per call (scipy-sa: dual annealing, 1,000 round trips
between the two processes) and two that ask for whole populations (pymoo-ga, cma-es). The
worker server is started once before timing, as a study does (its start, ~0.5-2 s, is per
process, not per run). Each timed call includes the optimizer's loading in its worker and the
worker's end, not the worker's fork: as in a study, the previous sandboxed run of the process
had the server fork it (adapters.sandbox.fork_spare), which it did while the in-process run
between them went on.
The figures are wall seconds per evaluation of the whole adapters.run call, filed as
"sandbox:<name>" and "inproc:<name>"; the session's ratio table (conftest.RATIOS) gives
in-process / sandboxed, whose goals are 1/1.5 (one point per call) and 1/1.1 (populations).
Beside them the runs' CPU seconds per evaluation ("sandbox-cpu:<name>": the evaluating process
and the worker with what it started; "inproc-cpu:<name>": the one process), which a loaded
machine does not stretch as it does wall time. Both modes give the same record (the same seed,
the same points): checked here.
"""

from __future__ import annotations

import time

import pytest

from adapters import run
from adapters.registry import module_of
from adapters.sandbox import server_address
from adapters.variants import make_problem

BUDGET = 1000
SEED = 0
ROUNDS = 5
NAMES = ("scipy-sa", "pymoo-ga", "cma-es")


@pytest.mark.benchmark(group="sandbox")
@pytest.mark.parametrize("name", NAMES)
def test_sandbox_cost(benchmark, record, name):
    """Both modes in turn within each round, so that both see the same load of a shared
    machine; the benchmark's own time is that of the pair."""
    server_address([module_of(n) for n in NAMES])  # started once, as in a study
    for isolated in (True, False):
        run(name, make_problem("paper"), 50, SEED, isolated=isolated)  # the optimizer's library imported
    records = {True: [], False: []}
    per_eval = {True: [], False: []}
    cpu_per_eval = {True: [], False: []}

    def one_round():
        for isolated in (True, False):
            problem = make_problem("paper")
            t0 = time.perf_counter()
            result = run(name, problem, BUDGET, SEED, isolated=isolated)
            per_eval[isolated].append((time.perf_counter() - t0) / BUDGET)
            cpu_per_eval[isolated].append(result.cpu_s / BUDGET)
            records[isolated].append(result)

    benchmark.pedantic(one_round, rounds=ROUNDS)
    for isolated, rs in records.items():
        assert all(r.status == "ok" and r.n_evals == BUDGET and r.verified == isolated for r in rs)
    # one seed, one run, whatever the mode: the same points, the same best
    assert len({(r.best_f, tuple(r.best_x)) for r in records[True] + records[False]}) == 1
    for isolated in (True, False):
        mode = "sandbox" if isolated else "inproc"
        record(f"{mode}-cpu:{name}", BUDGET, per_item_s=cpu_per_eval[isolated], budget=BUDGET, seed=SEED)
        record(f"{mode}:{name}", BUDGET, per_item_s=per_eval[isolated], budget=BUDGET, seed=SEED)
