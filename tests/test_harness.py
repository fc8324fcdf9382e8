"""The budget harness and the optimizer registry: exact budgets, traces, statuses, timing,
argument checks and third-party plugins, on the paper's H-frame problem."""

import json
import random
import sys
import textwrap
import time

import numpy as np
import pytest

import adapters
import fe_problem
from adapters import BudgetedObjective, BudgetExhausted, RunResult
from adapters.harness import seeded_global_rngs, unit_scaled
from adapters.variants import make_problem

# A third-party package as pip would install it: a module and its dist-info with entry points.
PLUGIN_MODULE = '''
from adapters import BudgetExhausted


class Sampler:
    """Uniform batches of 7 points until stopped."""
    name = "t-sampler"
    min_budget = 7

    def minimize(self, objective, bounds, budget, rng):
        while True:
            objective(rng.uniform(*bounds, size=(7, len(bounds[0]))))


class Raiser:
    name = "t-raiser"

    def minimize(self, objective, bounds, budget, rng):
        objective(rng.uniform(*bounds, size=(5, len(bounds[0]))))
        raise RuntimeError("plugin broke on purpose")


class EarlyReturn:
    name = "t-early"

    def minimize(self, objective, bounds, budget, rng):
        objective(rng.uniform(*bounds, size=(budget // 2, len(bounds[0]))))


class Wrapping:
    """A library that turns the harness's stop signal into its own error."""
    name = "t-wrapping"

    def minimize(self, objective, bounds, budget, rng):
        try:
            while True:
                objective(rng.uniform(*bounds, size=(9, len(bounds[0]))))
        except BudgetExhausted as exc:
            raise RuntimeError("library gave up") from exc


NOT_AN_OPTIMIZER = 42
'''

ENTRY_POINTS = """\
[femu.optimizers]
t-sampler = femu_test_plugins:Sampler
t-raiser = femu_test_plugins:Raiser
t-early = femu_test_plugins:EarlyReturn
t-wrapping = femu_test_plugins:Wrapping
t-not-a-class = femu_test_plugins:NOT_AN_OPTIMIZER
t-broken = femu_no_such_module:Thing
"""


@pytest.fixture(scope="module")
def plugins(tmp_path_factory):
    """Installs the test plugins for this module (on sys.path), then removes them."""
    root = tmp_path_factory.mktemp("site-packages")
    (root / "femu_test_plugins.py").write_text(textwrap.dedent(PLUGIN_MODULE))
    info = root / "femu_test_plugins-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: femu-test-plugins\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(ENTRY_POINTS)
    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(root))
        yield
    sys.modules.pop("femu_test_plugins", None)


class Logged:
    """The paper problem, remembering every row it evaluates and its value; optionally slow
    (sleep_s per call) or returning NaN from the nan_from-th evaluation on."""

    def __init__(self, sleep_s=0.0, nan_from=None):
        self.inner = make_problem("paper")
        self.n_var, self.xl, self.xu, self.x0 = self.inner.n_var, self.inner.xl, self.inner.xu, self.inner.x0
        self.sleep_s, self.nan_from = sleep_s, nan_from
        self.X, self.f = [], []

    def evaluate(self, X):
        time.sleep(self.sleep_s)
        f = self.inner.evaluate(X)
        if self.nan_from is not None:
            f[np.arange(len(self.f), len(self.f) + len(f)) >= self.nan_from] = np.nan
        self.X.extend(np.atleast_2d(X).copy())
        self.f.extend(f)
        return f


def test_budget_is_exact_when_a_batch_overshoots():
    p = make_problem("paper")
    obj = BudgetedObjective(p, 5)
    rng = np.random.default_rng(0)
    assert obj(rng.uniform(p.xl, p.xu, (3, p.n_var))).shape == (3,)
    with pytest.raises(BudgetExhausted):
        obj(rng.uniform(p.xl, p.xu, (4, p.n_var)))
    assert obj.n_evals == p.n_evals == 5  # the problem saw only the rows that fit
    with pytest.raises(BudgetExhausted):
        obj(p.x0)
    assert p.n_evals == 5

    p = make_problem("paper")  # through run(): batches of 100 against a budget of 250
    r = adapters.run("random-search", p, 250, seed=3)
    assert (r.status, r.n_evals, p.n_evals, r.error) == ("ok", 250, 250, None)


def test_trace_is_the_running_minimum_of_what_was_evaluated():
    p = Logged()
    r = adapters.run("random-search", p, 333, seed=11, batch_size=50)
    f = np.array(p.f)
    assert len(f) == r.n_evals == 333
    running = np.minimum.accumulate(f)
    improved = np.flatnonzero(np.r_[True, running[1:] < running[:-1]])
    expected = [[int(i) + 1, float(running[i])] for i in improved]
    if expected[-1][0] != 333:
        expected.append([333, float(running[-1])])
    assert r.trace == expected
    n, v = np.array(r.trace).T
    assert np.all(np.diff(n) > 0) and np.all(np.diff(v) <= 0) and n[-1] == r.n_evals
    for k in (1, 50, 51, 200, 333):
        assert r.best_at(k) == running[k - 1]
    assert r.best_at(0) == np.inf
    assert r.best_f == f.min()
    assert r.best_x == p.X[int(np.argmin(f))].tolist()
    # batched and single-point eigen-solves may differ in the last bits only
    assert p.inner.evaluate(np.array(r.best_x))[0] == pytest.approx(r.best_f, rel=1e-12)
    assert 0 < r.fe_s <= r.wall_s and r.cpu_s > 0
    assert RunResult.from_dict(json.loads(json.dumps(r.to_dict()))) == r


def test_failing_plugin_is_recorded_not_raised(plugins):
    r = adapters.run("t-raiser", make_problem("paper"), 100, seed=0)
    assert r.status == "failed"
    assert "RuntimeError: plugin broke on purpose" in r.error
    assert r.n_evals == 5 and np.isfinite(r.best_f) and r.trace[-1][0] == 5


def test_plugin_returning_early_is_stopped(plugins):
    r = adapters.run("t-early", make_problem("paper"), 100, seed=0)
    assert (r.status, r.n_evals, r.error) == ("stopped", 50, None)


def test_stop_signal_wrapped_by_a_library_still_ends_the_run_normally(plugins):
    r = adapters.run("t-wrapping", make_problem("paper"), 100, seed=0)
    assert (r.status, r.n_evals, r.error) == ("ok", 100, None)


def test_nan_objective_fails_the_run():
    p = Logged(nan_from=30)
    r = adapters.run("random-search", p, 100, seed=0, batch_size=20)
    assert r.status == "failed" and "the objective returned NaN at evaluation 31" in r.error
    # the valid rows of the failing batch still count
    assert r.n_evals == 40 and r.best_f == min(p.f[:30])
    assert r.trace[-2][0] <= 30 and r.trace[-1] == [40, r.best_f]


def test_time_limit_ends_the_run_as_timeout():
    p = Logged(sleep_s=0.02)
    r = adapters.run("random-search", p, 10**6, seed=0, time_limit_s=0.1, batch_size=10)
    assert r.status == "timeout" and "time limit" in r.error
    assert 0 < r.n_evals < 10**6 and r.n_evals == len(p.f)
    # checked before every batch: the run ends within one batch (20 ms) of the limit
    assert 0.1 <= r.wall_s < 1.0
    assert r.fe_s <= r.wall_s


def test_unknown_optimizer_lists_the_available_ones():
    with pytest.raises(ValueError, match="unknown optimizer 'nope'.*random-search.*cma-es"):
        adapters.run("nope", make_problem("paper"), 100, seed=0)


@pytest.mark.parametrize("seed", [-1, 1.5, True, "3", None])
def test_bad_seed_is_refused_before_anything_runs(seed):
    p = make_problem("paper")
    with pytest.raises(ValueError, match=r"seed must be an integer >= 0, got"):
        adapters.run("random-search", p, 100, seed=seed)
    assert p.n_evals == 0


@pytest.mark.parametrize("budget", [0, -5, 2.5, "100"])
def test_bad_budget_is_refused_before_anything_runs(budget):
    p = make_problem("paper")
    with pytest.raises(ValueError, match=r"budget must be an integer >= 1 \(FE evaluations\), got"):
        adapters.run("random-search", p, budget, seed=0)
    assert p.n_evals == 0


def test_budget_below_the_methods_minimum_is_refused():
    """min_budget is computed from the dimension: one initial population of max(20, n_var // 2)."""
    p = make_problem("paper")
    with pytest.raises(ValueError, match="'pymoo-ga' needs a budget of at least 20 evaluations, got 19"):
        adapters.run("pymoo-ga", p, 19, seed=0)
    assert p.n_evals == 0
    big = fe_problem.suite_problem("hframe-freq/96/1")
    for name in ("pymoo-ga", "deap-ga-stock"):
        with pytest.raises(ValueError, match=f"'{name}' needs a budget of at least 48 evaluations, got 47"):
            adapters.run(name, big, 47, seed=0)
    assert big.n_evals == 0
    assert adapters.run("pymoo-ga", big, 48, seed=0).n_evals == 48
    # the minimum follows an option it is given: CMA-ES's first generation is the popsize asked for
    with pytest.raises(ValueError, match="'cma-es' needs a budget of at least 30 evaluations, got 29"):
        adapters.run("cma-es", p, 29, seed=0, popsize=30)
    assert p.n_evals == 0


def test_least_squares_is_charged_a_finite_difference_jacobian_and_dated_after_it():
    """A Jacobian costs n_var + 1 evaluations (the point and a forward step per parameter),
    whatever the problem spends on it; residuals alone cost 1, and the Jacobian at the point
    just evaluated costs the n_var steps."""
    p = make_problem("paper")
    obj = BudgetedObjective(p, 30)
    assert obj.jacobian_cost == 13
    lower = p.xl.copy()  # most moduli on the lower bound fit the paper's data far better than x0
    out = obj.least_squares(p.x0)
    assert out.f == pytest.approx(make_problem("paper").evaluate(p.x0)[0], rel=1e-12)
    assert out.jacobian.shape == (5, 12) and obj.n_evals == 13 and obj.n_jacobians == 1
    cheap = obj.least_squares(lower, jacobian=False)
    assert cheap.jacobian is None and cheap.f < out.f and obj.n_evals == 14
    better = obj.least_squares(lower)
    assert better.f == cheap.f and obj.n_evals == 26 and obj.n_jacobians == 2
    assert obj.trace == [[13, out.f], [14, cheap.f]]  # best-so-far: the same value again adds nothing
    n_solved = p.n_evals
    with pytest.raises(BudgetExhausted):  # 4 evaluations left, a Jacobian costs 13
        obj.least_squares(p.x0)
    assert obj.n_evals == 26 and p.n_evals == n_solved
    with pytest.raises(BudgetExhausted):
        obj(np.vstack([p.x0] * 5))
    assert obj.n_evals == 30 and obj.finish_trace() == [[13, out.f], [14, cheap.f], [30, better.f]]


def test_third_party_plugin_is_listed_and_runs(plugins):
    names = adapters.available()
    assert names[:len(adapters.registry.BUILTINS)] == list(adapters.registry.BUILTINS)
    assert {"t-sampler", "t-raiser", "t-early", "t-wrapping"} <= set(names)
    assert adapters.get("t-sampler").__name__ == "Sampler"
    p = make_problem("paper")
    r = adapters.run("t-sampler", p, 100, seed=5)
    assert (r.optimizer, r.status, r.n_evals, p.n_evals) == ("t-sampler", "ok", 100, 100)
    assert r.best_f < p.evaluate(p.x0)[0]
    assert adapters.run("t-sampler", make_problem("paper"), 100, seed=5).trace == r.trace
    with pytest.raises(ValueError, match="'t-sampler' needs a budget of at least 7"):
        adapters.run("t-sampler", p, 6, seed=5)


def test_broken_plugins_get_a_clear_error(plugins):
    with pytest.raises(ValueError, match=r"'t-broken': entry point 'femu_no_such_module:Thing' .* could not be "
                                         r"loaded: ModuleNotFoundError"):
        adapters.run("t-broken", make_problem("paper"), 100, seed=0)
    with pytest.raises(ValueError, match="'t-not-a-class'.* is not an optimizer class"):
        adapters.get("t-not-a-class")


def test_seeded_global_rngs_fix_and_restore_the_global_streams():
    np.random.seed(123)
    random.seed(123)
    before_np, before_py = np.random.get_state()[1].copy(), random.getstate()
    draws = []
    for _ in range(2):
        with seeded_global_rngs(np.random.default_rng(9)):
            draws.append((np.random.rand(3).tolist(), random.random()))
    assert draws[0] == draws[1]
    assert np.array_equal(np.random.get_state()[1], before_np) and random.getstate() == before_py
    with seeded_global_rngs(np.random.default_rng(10)):
        assert (np.random.rand(3).tolist(), random.random()) != draws[0]


def test_unit_scaled_maps_the_cube_onto_the_bounds_and_never_leaves_them():
    p = make_problem("paper")
    obj = BudgetedObjective(p, 10)
    f, to_x = unit_scaled(obj, obj.bounds)
    U = np.array([np.zeros(12), np.ones(12), np.full(12, 0.5), np.r_[-1e-12, 1 + 1e-12, np.full(10, 0.25)]])
    X = to_x(U)
    np.testing.assert_array_equal(X[0], p.xl)
    np.testing.assert_array_equal(X[1], p.xu)
    np.testing.assert_allclose(X[2], p.x0, rtol=1e-15)
    assert (X[3, 0], X[3, 1]) == (p.xl[0], p.xu[1])  # round-off outside the cube is clipped
    assert np.array_equal(f(U), p.evaluate(X)) and obj.n_evals == 4
    assert f(U[2]).shape == (1,)  # a single point is a batch of one
