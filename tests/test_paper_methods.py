"""The paper's methods (deap-ga, mlp-surrogate) and the classical one (sensitivity) through
the harness, on the paper's data and on synthetic data with a known answer."""

import multiprocessing
import random
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

import fe_problem as fp
from adapters import BudgetedObjective, BudgetExhausted, run
from adapters.deap_ga import DeapGA, evolve
from adapters.ga_operators import latin_hypercube
from adapters.mlp_surrogate import MLP, MLPSurrogate, scg
from adapters.sensitivity import Sensitivity
from adapters.variants import SYNTHETIC_TRUTH, make_problem

# small budgets that still show each method working; mlp-surrogate: 150 initial + 50 refits
BUDGETS = {"deap-ga": 600, "mlp-surrogate": 200, "sensitivity": 200}
TIMING = ("wall_s", "cpu_s", "fe_s", "fe_cpu_s", "opt_cpu_s", "host")


def _record(name: str, seed: int) -> dict:
    """A run's record without the fields that vary from run to run (times, host)."""
    d = run(name, make_problem("paper"), BUDGETS[name], seed).to_dict()
    return {k: v for k, v in d.items() if k not in TIMING}


def _records_in_fresh_process(seed: int) -> dict:
    return {name: _record(name, seed) for name in BUDGETS}


@pytest.fixture(scope="module")
def records():
    """Every method with seeds 1 and 2, run once for the tests below."""
    return {(name, seed): _record(name, seed) for name in BUDGETS for seed in (1, 2)}


@pytest.fixture(scope="module")
def x0_value():
    p = make_problem("paper")
    f0 = float(p.evaluate(p.x0)[0])
    # the baseline really is the paper's initial model: 5.59 % mean frequency error, and J
    # equals eq. 4 evaluated by hand from the paired frequencies
    rep = p.correlation(p.x0)
    fm = rep.measured_hz
    assert rep.mean_abs_error_pct == pytest.approx(5.59, abs=0.01)
    assert f0 == pytest.approx(np.sum(((fm - rep.model_hz) / fm) ** 4), rel=1e-12)
    return f0


@pytest.mark.parametrize("name", list(BUDGETS))
def test_runs_exactly_the_budget_and_improves_on_x0(records, x0_value, name):
    r = records[(name, 1)]
    p = make_problem("paper")
    assert r["status"] == "ok" and r["error"] is None
    assert r["n_evals"] == BUDGETS[name] and r["trace"][-1][0] == BUDGETS[name]
    x = np.array(r["best_x"])
    assert x.shape == (12,) and np.all((x >= p.xl) & (x <= p.xu))
    # the record tells the truth about its point (sensitivity's values come from the
    # eigen-solve with vectors of least_squares, a different LAPACK path: equal to round-off)
    exact = r["best_f"] if name != "sensitivity" else pytest.approx(r["best_f"], rel=1e-9, abs=0)
    assert float(p.evaluate(x)[0]) == exact
    # every method at least quarters eq. 4 and lowers the mean frequency error from 5.59 %
    # to under 3 % (the bounded optimum is about 1.7 %, hframe.md)
    assert r["best_f"] < 0.25 * x0_value
    assert p.correlation(x).mean_abs_error_pct < 3.0


@pytest.mark.parametrize("name", list(BUDGETS))
def test_same_seed_same_record_even_after_global_rngs_move(records, name):
    random.seed(12345)
    np.random.seed(54321)
    state = random.getstate(), np.random.get_state()[1].copy()
    assert _record(name, 1) == records[(name, 1)]
    # and the run left the global generators where they were
    assert random.getstate() == state[0]
    np.testing.assert_array_equal(np.random.get_state()[1], state[1])


def test_same_seed_same_record_in_a_spawned_process(records):
    with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn")) as pool:
        fresh = pool.submit(_records_in_fresh_process, 1).result()
    for name in BUDGETS:
        assert fresh[name] == records[(name, 1)], name


@pytest.mark.parametrize("name", ["deap-ga", "mlp-surrogate"])
def test_different_seeds_differ(records, name):
    a, b = records[(name, 1)], records[(name, 2)]
    assert a["best_x"] != b["best_x"] and a["trace"] != b["trace"]


class _Recording(BudgetedObjective):
    """The harness's objective, also remembering every batch and least-squares point, and what
    each least-squares call was charged."""

    def __init__(self, problem, budget):
        super().__init__(problem, budget)
        self.batches, self.ls_points, self.ls_calls = [], [], []

    def __call__(self, X):
        self.batches.append(np.atleast_2d(X).copy())
        return super().__call__(X)

    def least_squares(self, x, jacobian: bool = True):
        self.ls_points.append(np.array(x, dtype=float))
        before = self.n_evals
        try:
            return super().least_squares(x, jacobian=jacobian)
        finally:
            self.ls_calls.append((jacobian, self.n_evals - before))


def _drive(optimizer, problem, budget, seed, **options):
    objective = _Recording(problem, budget)
    try:
        optimizer.minimize(objective, objective.bounds, budget, np.random.default_rng(seed), **options)
        finished = "stopped"
    except BudgetExhausted:
        finished = "ok"
    return objective, finished


def test_sensitivity_seed_chooses_restarts_and_pays_a_finite_difference_jacobian():
    x0 = make_problem("paper").x0
    first_fit, finished = _drive(Sensitivity(), make_problem("paper"), 5000, 1, x0=x0, restarts=False)
    assert finished == "stopped"
    n_first = len(first_fit.ls_points)
    problems = {seed: make_problem("paper") for seed in (1, 2)}
    a, b = (_drive(Sensitivity(), problems[seed], 3000, seed, x0=x0)[0] for seed in (1, 2))
    again = _drive(Sensitivity(), make_problem("paper"), 3000, 1, x0=x0)[0]
    for obj in (a, b):
        assert obj.n_evals == 3000
        # residuals alone cost 1; the Jacobian at the point just evaluated costs n_var = 12 more
        # (a forward-difference Jacobian: n_var + 1 in all); points bought after the last
        # affordable Jacobian are uniform draws, one evaluation each
        assert all(cost == (12 if jac else 1) for jac, cost in obj.ls_calls[:-1])
        n_fill = sum(len(batch) for batch in obj.batches)
        assert sum(cost for _, cost in obj.ls_calls) + n_fill == 3000
        np.testing.assert_array_equal(obj.ls_points[0], x0)
    # the first fit starts at x0 and uses no randomness; the seed chooses the restarts
    np.testing.assert_array_equal(np.array(a.ls_points[:n_first]), np.array(first_fit.ls_points))
    np.testing.assert_array_equal(np.array(b.ls_points[:n_first]), np.array(first_fit.ls_points))
    assert not np.array_equal(a.ls_points[n_first], b.ls_points[n_first])
    np.testing.assert_array_equal(np.array(a.ls_points), np.array(again.ls_points))


def test_sensitivity_without_restarts_stops_by_itself():
    r = run("sensitivity", make_problem("paper"), 5000, 0, restarts=False, x0="all")
    assert r.status == "stopped" and 50 < r.n_jacobians < 300 and r.n_evals < 5000
    # the bounded fit of the five frequencies: mean error about 1.7 % (hframe.md)
    err = make_problem("paper").correlation(r.best_x).mean_abs_error_pct
    assert err == pytest.approx(1.74, abs=0.02)
    import re
    from pathlib import Path

    page = " ".join((Path(__file__).resolve().parents[1] / "docs" / "hframe.md").read_text().split())
    said = re.search(r"leaves a mean absolute error of about ([\d.]+) % \(eq\. 4 weights\)", page)
    assert said and said[1] == f"{err:.1f}", "docs/hframe.md: the bounded fit's mean error"


@pytest.mark.parametrize("truth", [SYNTHETIC_TRUTH, {3: 6.3e10, 5: 6.5e10, 10: 7.6e10, 12: 6.1e10}])
def test_sensitivity_recovers_moduli_from_noise_free_data(truth):
    # 14 noise-free frequencies determine the 12 moduli (8 would not: fewer equations than unknowns)
    model = fp.load_model("hframe").with_element_moduli(truth)
    data = fp.synthetic_measurement(model, n_modes=14, model_name="hframe")
    problem = fp.UpdatingProblem("hframe", data, weights="unit")
    expected = np.array([truth.get(e, 7.0e10) for e in range(1, 13)])
    r = run("sensitivity", problem, 500, 0, restarts=False, x0="all")
    assert r.status == "stopped" and r.n_jacobians < 20
    np.testing.assert_allclose(r.best_x, expected, rtol=1e-6)
    assert r.best_f < 1e-15


def test_sensitivity_on_the_synthetic_frequencies_finds_the_damaged_elements():
    # the synthetic variant's 8 frequencies alone (0.2 % noise, unit weights): not exact, but the
    # two softened elements stand out, within 2 % of the hidden moduli, the others near 7e10
    from adapters.variants import _synthetic_data

    problem = fp.UpdatingProblem("hframe", _synthetic_data(), weights="unit")
    r = run("sensitivity", problem, 5000, 0, restarts=False, x0="all")
    assert r.status == "stopped" and r.n_jacobians < 250
    x = np.array(r.best_x)
    assert sorted(np.argsort(x)[:2] + 1) == sorted(SYNTHETIC_TRUTH)
    for e, modulus in SYNTHETIC_TRUTH.items():
        assert x[e - 1] == pytest.approx(modulus, rel=0.02)
    others = np.delete(x, [e - 1 for e in SYNTHETIC_TRUTH])
    np.testing.assert_allclose(others, 7.0e10, rtol=0.03)


def test_sensitivity_fits_the_whole_residual_of_the_synthetic_variant():
    """With the shape term (1 - MAC per mode) the method fits J itself: the residuals' sum of
    squares is J, its point is the one scipy's least_squares finds from x0 on the problem's
    residuals with its own finite-difference Jacobian, and J there is below J at the hidden truth
    (2 % shape noise) and below the frequency-only fit's."""
    from scipy.optimize import least_squares

    from adapters.variants import _synthetic_data

    p = make_problem("synthetic")
    out = p.least_squares(p.x0)
    assert np.sum(out.residuals**2) == pytest.approx(float(p.evaluate(p.x0)[0]), rel=1e-9)
    assert out.jacobian.shape == (len(out.residuals), 12) and len(out.residuals) > 8  # shapes are in
    r = run("sensitivity", make_problem("synthetic"), 5000, 0, restarts=False, x0="all")
    assert r.status == "stopped" and r.n_jacobians < 60
    span = p.xu - p.xl
    ref = least_squares(lambda u: p.least_squares(p.xl + u * span, charged=1).residuals, np.full(12, 0.5),
                        bounds=(0.0, 1.0), method="trf", x_scale=1.0, ftol=1e-12, xtol=1e-12, gtol=1e-12)
    assert r.best_f == pytest.approx(2 * ref.cost, rel=1e-4)
    truth = np.array([SYNTHETIC_TRUTH.get(e, 7.0e10) for e in range(1, 13)])
    assert r.best_f < float(p.evaluate(truth)[0])
    freq_only = run("sensitivity", fp.UpdatingProblem("hframe", _synthetic_data(), weights="unit"), 5000, 0,
                    restarts=False, x0="all")
    assert r.best_f < 0.95 * float(p.evaluate(np.array(freq_only.best_x))[0])


def test_mlp_surrogate_evaluates_the_design_then_one_point_per_refit():
    obj, finished = _drive(MLPSurrogate(), make_problem("paper"), 70, 3)
    assert finished == "ok"
    assert [len(b) for b in obj.batches] == [26] + [1] * 44  # 2 (n_var + 1) design points, whatever the budget
    U = (obj.batches[0] - obj.bounds[0]) / (obj.bounds[1] - obj.bounds[0])
    for j in range(12):  # a Latin hypercube in the bounds
        np.testing.assert_array_equal(np.sort(np.floor(U[:, j] * 26)), np.arange(26))
    # every refit's point lies in the trust region: within length_max / 2 of the best point before it
    span, p = obj.bounds[1] - obj.bounds[0], make_problem("paper")
    for k in range(1, len(obj.batches)):
        seen = np.vstack(obj.batches[:k])
        best = seen[np.argmin(p.evaluate(seen))]
        assert np.all(np.abs(obj.batches[k][0] - best) <= 0.4 * span + 1e-9 * span)
    short, _ = _drive(MLPSurrogate(), make_problem("paper"), 20, 3)
    assert [len(b) for b in short.batches] == [26] and short.n_evals == 20  # the design's first 20 points
    np.testing.assert_array_equal(short.batches[0], obj.batches[0])


def test_mlp_surrogate_warm_start_rescaling_is_the_same_function():
    """_refitted_scales: the network with transformed weights on rescaled inputs and targets
    predicts the same values of y(u) as before, to round-off."""
    from adapters.mlp_surrogate import _refitted_scales

    rng = np.random.default_rng(0)
    net = MLP(5, 8)
    w = net.init(rng) * 3.0
    c0, s0, m0, d0 = rng.random(5), rng.random(5) + 0.1, -3.0, 2.0
    c1, s1, m1, d1 = rng.random(5), rng.random(5) + 0.1, -7.5, 0.3
    u = rng.random((50, 5))
    y0 = m0 + d0 * net.predict(w, (u - c0) / s0)
    w1 = _refitted_scales(w, net, (c1 - c0) / s0, s1 / s0, (m0 - m1) / d1, d0 / d1)
    y1 = m1 + d1 * net.predict(w1, (u - c1) / s1)
    np.testing.assert_allclose(y1, y0, rtol=1e-12, atol=1e-12)


def test_deap_ga_batches_are_generations_and_paper_settings_run():
    obj, _ = _drive(DeapGA(), make_problem("paper"), 500, 0)
    sizes = [len(b) for b in obj.batches]
    assert sizes[0] == 50 and set(sizes[1:]) == {48}  # population 50, 2 elites kept unevaluated
    r = run("deap-ga", make_problem("paper"), 1500, 0, population=600, generations=100)
    assert r.status == "ok" and r.n_evals == 1500
    bad = run("deap-ga", make_problem("paper"), 500, 0, population=600)
    assert bad.status == "failed" and "population=600 exceeds the budget of 500" in bad.error


def test_evolve_keeps_its_elite_and_converges_on_a_sphere():
    centre = np.linspace(0.2, 0.8, 12)
    res = evolve(lambda U: np.sum((U - centre) ** 2, axis=1), 12, np.random.default_rng(0), 50, 150)
    best = res.logbook.select("best")
    assert all(b <= a for a, b in zip(best, best[1:]))
    assert res.n_evals == 50 + 149 * 48
    assert res.f == best[-1] < 1e-4
    np.testing.assert_allclose(res.x, centre, atol=0.01)


def test_mlp_gradient_matches_finite_differences():
    rng = np.random.default_rng(0)
    net = MLP(12, 8)
    X, t, w = rng.uniform(-1, 1, (40, 12)), rng.standard_normal(40), net.init(rng)
    g = net.gradient(w, X, t)
    assert g.shape == (net.n_weights,) == (113,)
    h = 1e-6
    fd = np.array([(net.error(w + h * e, X, t) - net.error(w - h * e, X, t)) / (2 * h) for e in np.eye(len(w))])
    np.testing.assert_allclose(g, fd, rtol=1e-6, atol=1e-8 * np.abs(g).max())


def test_scg_is_conjugate_on_a_quadratic():
    # 10-D convex quadratic with condition number 100: steepest descent would need ~1000 steps
    # for 1e-6; conjugate directions get there in a few times n
    rng = np.random.default_rng(0)
    Q, _ = np.linalg.qr(rng.standard_normal((10, 10)))
    A = Q @ np.diag(np.logspace(0, 2, 10)) @ Q.T
    b = rng.standard_normal(10)
    w, errors = scg(lambda w: 0.5 * w @ A @ w - b @ w, lambda w: A @ w - b, np.zeros(10), 50)
    solution = np.linalg.solve(A, b)
    assert np.abs(w - solution).max() < 1e-6 * np.abs(solution).max()
    assert all(e2 <= e1 for e1, e2 in zip(errors, errors[1:]))


def test_mlp_trained_by_scg_fits_a_quadratic_in_12_variables():
    # a rank-3 quadratic form in 12 inputs (what a few frequencies make of 12 moduli), 300
    # Latin-hypercube training points, 1000 held-out points
    rng = np.random.default_rng(0)
    A, c = 0.3 * rng.standard_normal((3, 12)), 0.3 * rng.standard_normal(3)

    def quadratic(Z):
        return np.sum((Z @ A.T + c) ** 2, axis=1)

    Z, Z_test = 2 * latin_hypercube(300, 12, rng) - 1, rng.uniform(-1, 1, (1000, 12))
    t, t_test = quadratic(Z), quadratic(Z_test)
    mean, std = t.mean(), t.std()
    net = MLP(12, 8)

    def r_squared(cycles):
        w, _ = scg(lambda w: net.error(w, Z, (t - mean) / std), lambda w: net.gradient(w, Z, (t - mean) / std),
                   net.init(np.random.default_rng(1)), cycles)
        return 1 - np.mean((net.predict(w, Z_test) * std + mean - t_test) ** 2) / np.var(t_test)

    # the best linear fit explains little of it: the network must learn the curvature
    design = np.column_stack([Z, np.ones(len(Z))])
    coef = np.linalg.lstsq(design, t, rcond=None)[0]
    linear = 1 - np.mean((np.column_stack([Z_test, np.ones(1000)]) @ coef - t_test) ** 2) / np.var(t_test)
    assert linear < 0.6
    assert r_squared(200) > 0.97  # the paper's 200 cycles
    assert r_squared(1000) > 0.99
