"""The library optimizers (pymoo GA, DEAP's stock GA, PySwarms PSO, scipy dual annealing, pycma
CMA-ES, nevergrad NGOpt, optuna CMA-ES and TPE; random search for seeds) under
the harness on the paper's H-frame problem: exact budgets, seeds that fix a run exactly in any
process, silence, and real progress."""

import logging
import multiprocessing
import random
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

import adapters
from adapters.variants import make_problem

LIBRARY = ["pymoo-ga", "deap-ga-stock", "pyswarms-pso", "scipy-sa", "cma-es", "nevergrad-ngopt", "optuna-cmaes",
           "optuna-tpe"]


def record(name, seed, budget, **options):
    """What fixes a run: status, evaluations, best point, best value, trace."""
    r = adapters.run(name, make_problem("paper"), budget, seed, **options)
    return r.status, r.n_evals, r.best_x, r.best_f, r.trace


def record_in_worker(name, seed, budget):
    """`record` in a fresh process, with the root logger's handlers it ended with."""
    return record(name, seed, budget), len(logging.getLogger().handlers)


@pytest.fixture(scope="module")
def spawned():
    """One fresh interpreter ('spawn'), its global generators seeded from OS entropy."""
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        yield pool


@pytest.mark.parametrize("name", LIBRARY)
def test_spends_exactly_the_budget_inside_the_bounds(name):
    p = make_problem("paper")
    r = adapters.run(name, p, 250, seed=1)  # 250: not a whole number of populations
    assert (r.status, r.error, r.n_evals, p.n_evals) == ("ok", None, 250, 250)
    assert r.trace[-1] == [250, r.best_f]
    x = np.array(r.best_x)
    assert np.all(x >= p.xl) and np.all(x <= p.xu)
    assert 0 < r.fe_s <= r.wall_s


@pytest.mark.parametrize("name", LIBRARY + ["random-search"])
def test_seed_fixes_the_run_in_process_and_in_a_spawned_worker(name, spawned):
    worker = spawned.submit(record_in_worker, name, 7, 250)
    np.random.seed(1)
    random.seed(1)
    first = record(name, 7, 250)
    # the global generators are left as they were ...
    np.random.seed(2)
    random.seed(2)
    state, py_state = np.random.get_state()[1].copy(), random.getstate()
    second = record(name, 7, 250)
    assert np.array_equal(np.random.get_state()[1], state) and random.getstate() == py_state
    # ... and their state does not change the run
    assert second == first
    in_worker, root_handlers = worker.result(timeout=120)
    assert in_worker == first
    # importing and running the library configured no logging in the fresh process
    assert root_handlers == 0
    other = record(name, 8, 250)
    assert other[2] != first[2] and other[4] != first[4]


@pytest.mark.parametrize("name", LIBRARY)
def test_runs_silently_and_leave_logging_and_cwd_alone(name, capfd, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    handlers = list(logging.getLogger().handlers)
    adapters.run(name, make_problem("paper"), 120, seed=0)
    assert capfd.readouterr() == ("", "")
    assert logging.getLogger().handlers == handlers
    assert list(tmp_path.iterdir()) == []  # no report.log, no outcmaes/


#: The budget at which every library must improve on random search: 300, where the worst of
#: them (deap-ga-stock, seed 0) ends at 0.47 of random search's best J and the others at 0.16-0.37
#: (the same property as at 1,000 evaluations, where it was tested before at four times the CPU:
#: optuna-tpe's own cost grows with its history).
IMPROVE_BUDGET = 300


@pytest.fixture(scope="module")
def random_search_baseline():
    """The best J of random search (IMPROVE_BUDGET evaluations, seed 0) every library must beat at
    the same budget: one run (a seed fixes it: test_seed_fixes_the_run_...), not one per library."""
    return adapters.run("random-search", make_problem("paper"), IMPROVE_BUDGET, seed=0).best_f


@pytest.mark.parametrize("name", LIBRARY)
def test_improves_on_the_initial_model_and_on_random_search(name, random_search_baseline):
    p = make_problem("paper")
    r = adapters.run(name, p, IMPROVE_BUDGET, seed=0)
    assert r.n_evals == IMPROVE_BUDGET
    assert r.best_f < p.evaluate(p.x0)[0]
    assert r.best_f < random_search_baseline


@pytest.mark.parametrize("name, options, longest_run", [
    # one annealing run without local search: the start and 2 iterations of 2 x 12 visits
    ("scipy-sa", {"maxiter": 2, "no_local_search": True}, 1 + 2 * 24),
    # one CMA-ES run of 3 generations of 11, then 22, 44, ... (IPOP)
    ("cma-es", {"cma_options": {"maxiter": 3}}, 3 * 11),
])
def test_restarts_spend_the_budget_when_the_library_stops(name, options, longest_run):
    budget = 300
    assert budget > longest_run  # so the first run alone cannot have spent it
    first = record(name, 3, budget, **options)
    assert first[:2] == ("ok", budget)
    assert record(name, 3, budget, **options) == first


def test_ngopt_with_its_threaded_cma_is_fixed_by_the_seed(spawned):
    # at 12 parameters and more than 600 evaluations NGOpt picks a MetaModel over CmaFmin2, whose
    # pycma runs in a thread of nevergrad's, unseeded: before the adapter seeded it and ordered
    # the threads' draws, two runs with one seed differed. 650 evaluations (1,000 before: the
    # same choice, asserted here, at two thirds of the CPU; at 600 and below NGOpt picks NGOpt16)
    import nevergrad as ng

    budget = 650
    chosen = ng.optimizers.NGOpt(parametrization=ng.p.Array(shape=(12,), lower=0.0, upper=1.0), budget=budget)
    assert "CmaFmin2" in str(chosen._select_optimizer_cls())
    worker = spawned.submit(record_in_worker, "nevergrad-ngopt", 3, budget)
    first = record("nevergrad-ngopt", 3, budget)
    assert first[:2] == ("ok", budget)
    assert record("nevergrad-ngopt", 3, budget) == first
    assert worker.result(timeout=300)[0] == first
