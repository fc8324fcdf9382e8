"""What an optimizer and the harness cost on top of the FE evaluations, per evaluation.

For every optimizer in adapters.registry.available(), adapters.run() on the paper problem
with BUDGET evaluations and a fixed seed; the figure is (wall_s - fe_s) / n_evals from the
run record (time outside UpdatingProblem.evaluate: the optimizer's own work plus the
harness's bookkeeping), filed as "overhead:<name>" for the session summary and in the
benchmark's extra_info. The benchmark's own time is that of the whole run.

The optimizer's module is imported only when its run starts (registry.get), so an adapter
that is listed but not written yet makes its benchmark error, not the whole suite.
"""

from __future__ import annotations

import pytest

from adapters import available, get, min_budget, run
from adapters.variants import make_problem

#: FE evaluations per run, raised to the optimizer's `min_budget` where that is larger.
BUDGET = 500
SEED = 0
ROUNDS = 3


@pytest.mark.benchmark(group="harness-overhead")
@pytest.mark.parametrize("name", available())
def test_harness_overhead(benchmark, record, name):
    budget = max(BUDGET, min_budget(get(name), make_problem("paper").n_var))
    records = []

    def one_run(problem):
        result = run(name, problem, budget, SEED)
        records.append(result)
        return result

    # A fresh problem per round: its evaluation counter starts at zero.
    benchmark.pedantic(one_run, setup=lambda: ((make_problem("paper"),), {}), rounds=ROUNDS)
    for r in records:
        assert r.status in ("ok", "stopped"), f"{name} run {r.status}: {r.error}"
        assert 0 < r.n_evals <= budget and (r.status == "stopped" or r.n_evals == budget)
        assert 0.0 <= r.fe_s <= r.wall_s
    # One seed fixes a run: every round found the same best point.
    assert len({(r.n_evals, r.best_f) for r in records}) == 1, f"{name}: seed {SEED} gave different runs"
    record(f"overhead:{name}", records[0].n_evals,
                 per_item_s=[(r.wall_s - r.fe_s) / r.n_evals for r in records],
                 budget=budget, seed=SEED, fe_s_per_eval=min(r.fe_s / r.n_evals for r in records))
