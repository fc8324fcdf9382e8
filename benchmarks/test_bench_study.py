"""A small study end to end: the cost of the study machinery around the runs.

femu.studies.study.run_study(['random-search'], seeds 0-3, budget 500, a fresh store,
workers=2): process-pool start-up, four runs of 500 evaluations, four records written to
the store. Compare its time with 4 x the per-run time of test_bench_harness.py's
random-search benchmark to see what the pool and the store add. The figure filed is the
wall time per run ("study:random-search", per item = per run).
"""

from __future__ import annotations

import itertools

import pytest

from femu.studies.store import Store, run_key
from femu.studies.study import run_study

OPTIMIZERS = ["random-search"]
SEEDS = [0, 1, 2, 3]
BUDGET = 500
WORKERS = 2
ROUNDS = 3


@pytest.mark.benchmark(group="study")
def test_small_study(benchmark, record, tmp_path):
    counter = itertools.count()
    stores = []

    def fresh_store():
        # A study skips the runs already in its store: every round needs an empty one.
        stores.append(tmp_path / f"store{next(counter)}")
        return (OPTIMIZERS, SEEDS, BUDGET, stores[-1]), {"workers": WORKERS, "progress": False}

    benchmark.pedantic(run_study, setup=fresh_store, rounds=ROUNDS)
    expected = {run_key("paper", o, BUDGET, s) for o in OPTIMIZERS for s in SEEDS}
    first = None
    for path in stores:
        runs = Store(path).runs()
        assert {run_key(r.variant, r.optimizer, r.budget, r.seed) for r in runs} == expected
        assert all(r.status == "ok" and r.n_evals == BUDGET for r in runs), [(r.status, r.error) for r in runs]
        # Same seeds, same study: the stores of all rounds hold the same results.
        results = [(r.seed, r.best_f, r.best_x) for r in runs]
        assert first is None or results == first
        first = results
    record("study:random-search", len(expected), workers=WORKERS, budget=BUDGET, seeds=len(SEEDS))
