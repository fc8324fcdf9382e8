"""The suite's problems in other harnesses (femu.harnesses): ioh with its logger, pymoo,
Nevergrad, optuna; each value checked against the suite problem evaluated here."""

import numpy as np
import pytest

import fe_problem as fp
from femu import harnesses
from femu.reports.ioh import FUNCTION_IDS, read_ioh

PID = "hframe-freq/12/4"


@pytest.fixture(scope="module")
def reference():
    """The suite problem, evaluated apart from the harnesses' own copies."""
    return fp.suite_problem(PID)


def test_ioh_problem_logs_with_its_analyzer(reference, tmp_path):
    import ioh

    p = harnesses.ioh_problem(PID)
    assert (p.meta_data.problem_id, p.meta_data.instance, p.meta_data.n_variables) == (FUNCTION_IDS["hframe-freq"], 4, 12)
    scale = 100 * fp.suite.TARGET_SCALE["hframe-freq"]
    # the optimum: the hidden truth in [0, 1]^n, raw_y 0 (f_opt 0 on a noise-free instance)
    xl, xu = np.asarray(reference.xl), np.asarray(reference.xu)
    np.testing.assert_allclose(p.optimum.x, (reference.truth - xl) / (xu - xl), rtol=1e-12)
    assert p.optimum.y == 0.0 and abs(p(np.asarray(p.optimum.x))) < 1e-10
    p.reset()  # ioh writes no .json for a run that began before its logger was attached
    logger = ioh.logger.Analyzer(root=str(tmp_path), folder_name="rs", algorithm_name="rs")
    p.attach_logger(logger)
    X = np.random.default_rng(0).uniform(0, 1, (25, 12))
    ys = [p(x) for x in X]
    p.reset()
    logger.close()
    want = reference.evaluate(xl + X * (xu - xl)) / scale
    np.testing.assert_allclose(ys, want, rtol=1e-12)
    (run,) = read_ioh(tmp_path)
    assert run.function_id == FUNCTION_IDS["hframe-freq"] and run.instance == 4 and run.evals == 25
    assert run.best_y == pytest.approx(want.min(), rel=1e-9)
    # its .dat holds the improvements of the values it was given (ioh writes 10 decimals)
    best = np.minimum.accumulate(want)
    firsts = np.flatnonzero(np.r_[True, best[1:] < best[:-1]])
    np.testing.assert_allclose(run.points[: len(firsts)], np.c_[firsts + 1, best[firsts]], atol=1e-9)


def test_ioh_problems_of_one_family_live_side_by_side(reference):
    other = fp.suite_problem("hframe-freq/12/1")
    a, b = harnesses.ioh_problem("hframe-freq/12/1"), harnesses.ioh_problem(PID)
    x = np.linspace(0.1, 0.9, 12)
    xl, xu = np.asarray(reference.xl), np.asarray(reference.xu)
    scale = 100 * fp.suite.TARGET_SCALE["hframe-freq"]
    for _ in range(2):  # interleaved: each answers with its own instance
        assert a(x) == pytest.approx(other.evaluate((xl + x * (xu - xl))[None])[0] / scale, rel=1e-12)
        assert b(x) == pytest.approx(reference.evaluate((xl + x * (xu - xl))[None])[0] / scale, rel=1e-12)
    assert a(x) != pytest.approx(b(x), rel=1e-3)


def test_pymoo_problem_evaluates_a_population_and_runs_a_ga(reference):
    from pymoo.algorithms.soo.nonconvex.ga import GA
    from pymoo.optimize import minimize

    problem = harnesses.pymoo_problem(PID)
    assert problem.n_var == 12 and np.array_equal(problem.xl, reference.xl) and np.array_equal(problem.xu, reference.xu)
    X = np.random.default_rng(1).uniform(reference.xl, reference.xu, (7, 12))
    np.testing.assert_allclose(problem.evaluate(X).ravel(), reference.evaluate(X), rtol=1e-12)
    res = minimize(problem, GA(pop_size=10), ("n_evals", 40), seed=1)
    assert res.F[0] == pytest.approx(reference.evaluate(res.X[None, :])[0], rel=1e-12)
    assert problem.problem.n_evals >= 40
    assert res.F[0] < reference.evaluate(reference.x0[None, :])[0]


def test_nevergrad_function_with_bounds(reference):
    import nevergrad as ng

    f = harnesses.nevergrad_function(PID)
    arr = f.parametrization
    np.testing.assert_array_equal(arr.bounds[0], reference.xl)
    np.testing.assert_array_equal(arr.bounds[1], reference.xu)
    np.testing.assert_array_equal(arr.value, reference.x0)
    opt = ng.optimizers.OnePlusOne(parametrization=f.parametrization, budget=30)
    opt.parametrization.random_state = np.random.RandomState(0)
    rec = opt.minimize(f)
    x = np.asarray(rec.value)
    assert np.all((x >= reference.xl) & (x <= reference.xu))
    assert f(x) == pytest.approx(reference.evaluate(x[None, :])[0], rel=1e-12)
    assert f.femu_problem.n_evals >= 30


def test_optuna_objective_suggests_named_parameters(reference):
    import optuna

    objective = harnesses.optuna_objective(PID)
    assert objective.names == [q.name for q in reference.parameters]
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=0))
    study.optimize(objective, n_trials=8)
    x = np.array([study.best_params[n] for n in objective.names])
    assert np.all((x >= reference.xl) & (x <= reference.xu))
    assert study.best_value == pytest.approx(reference.evaluate(x[None, :])[0], rel=1e-12)
    assert objective.problem.n_evals == 8


def test_a_missing_library_is_one_line(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "optuna", None)  # as if not installed: its import raises ImportError
    with pytest.raises(ValueError, match=r"the optuna harness needs the 'optimizers' extra: pip install 'femu-bench\[optimizers\]'"):
        harnesses.optuna_objective(PID)
