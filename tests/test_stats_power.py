"""The benchmark report's power statement (femu.reports.stats.min_blocks, wilcoxon_power) against
scipy's exact tests and simulated Wilcoxon tests, and the anytime aggregates: solvers that are not
anytime kept out, ECDF levels below every start."""

import math

import numpy as np
import pytest
from scipy import stats as sps

from femu.reports import stats as st

ALPHA = 0.05


@pytest.mark.parametrize("pairs", [1, 3, 6])
def test_min_blocks_is_where_scipys_exact_wilcoxon_first_reaches_the_holm_level(pairs):
    n = st.min_blocks("wilcoxon", ALPHA, n_tests=pairs)
    # every difference of one sign: the smallest p the exact signed-rank test gives
    assert sps.wilcoxon(np.arange(1.0, n + 1)).pvalue <= ALPHA / pairs
    assert sps.wilcoxon(np.arange(1.0, n)).pvalue > ALPHA / pairs


def test_min_blocks_of_friedman_against_scipy():
    for k in (3, 4):
        n = st.min_blocks("friedman", ALPHA, k=k)
        alike = lambda n: [np.arange(n) * 0 + j for j in range(k)]  # noqa: E731  (every block ranks alike)
        assert sps.friedmanchisquare(*alike(n)).pvalue <= ALPHA < sps.friedmanchisquare(*alike(n - 1)).pvalue


def _simulated_power(n: int, dz: float, level: float, reps: int = 4000, seed: int = 0) -> float:
    """The fraction of scipy Wilcoxon tests on n normal differences (mean dz, sd 1) with p <= level."""
    x = np.random.default_rng(seed).normal(dz, 1.0, (reps, n))
    return float((sps.wilcoxon(x, axis=1).pvalue <= level).mean())


@pytest.mark.parametrize("n, pairs", [(10, 1), (20, 3)])
def test_the_detectable_difference_has_the_stated_power_in_simulation(n, pairs):
    w = st.wilcoxon_power(n, pairs, ALPHA)
    assert w["level"] == ALPHA / pairs and w["min_problems"] <= n
    assert abs(_simulated_power(n, w["detectable_dz"], w["level"]) - 0.8) < 0.04


def test_the_problems_needed_give_the_stated_power_in_simulation():
    w = st.wilcoxon_power(4, 3, ALPHA)  # the issue's case: 4 problems, 3 solvers
    assert w["detectable_dz"] is None and w["min_problems"] == 7  # 2 / 2^7 <= 0.05 / 3 < 2 / 2^6
    for dz, n in w["problems_needed"].items():
        assert abs(_simulated_power(n, dz, w["level"], seed=n) - 0.8) < 0.04, (dz, n)
    assert w["problems_needed"][0.5] > w["problems_needed"][0.8] > w["problems_needed"][1.2]


@pytest.fixture(scope="module")
def mixed(tmp_path_factory):
    from femu.reports.benchmark import benchmark_statistics
    from femu.studies.study import run_study

    result = run_study("scipy-sa,random-search,cma-es", "0-1", 150, tmp_path_factory.mktemp("mixed") / "s",
                       suite="hframe-freq/12/1,hframe-freq/12/4", workers=0, progress=False,
                       blind=False)  # the public instances, whose starts the ECDF test below knows
    return list(result.runs), benchmark_statistics(list(result.runs))


def test_solvers_not_anytime_are_kept_out_of_the_anytime_aggregates(mixed):
    runs, s = mixed
    assert s["one_budget"] == {"scipy-sa": 150}
    assert s["anytime_aggregates"] == ["cma-es", "random-search"]
    assert {e.solver for e in s["ecdf"]} == {"cma-es", "random-search"}
    assert set(s["aggregate"].fraction) == {"cma-es", "random-search"}
    assert all(set(p.data) == {"cma-es", "random-search"} for p in s["profiles"])
    assert "scipy-sa" in s["ert"].ert  # the ERT table keeps it, marked
    # its one point: the fraction of (run, target) pairs its runs end below, computed here
    k = s["first_levels"]["hframe-freq/12"]
    targets = {p["id"]: p for p in s["problems"]}
    hit = [r.best_f - targets[r.variant]["f_opt"] <= d for r in runs if r.optimizer == "scipy-sa"
           for d in targets[r.variant]["targets"][k:]]
    assert s["one_budget_reached"]["scipy-sa"]["hframe-freq/12"] == pytest.approx(np.mean(hit), abs=1e-15)


def test_the_ecdf_levels_start_below_every_instances_start(mixed):
    runs, s = mixed
    k = s["first_levels"]["hframe-freq/12"]
    gaps = [p["f_start"] - p["f_opt"] for p in s["problems"]]
    targets = [p["targets"] for p in s["problems"]]
    assert k > 0 and all(t[k] < g for t, g in zip(targets, gaps))
    assert any(t[k - 1] >= g for t, g in zip(targets, gaps))
    # here no solver reaches the ECDFs' first level at its first evaluation (every run has one)
    assert all(r.trace[0][0] == 1 for r in runs)
    for e in s["ecdf"]:
        assert e.fraction[0] == 0.0 and e.budgets[0] == 1


def test_the_report_states_the_power_and_the_kept_out_solvers(mixed):
    from femu.reports.benchmark import render_benchmark

    _, s = mixed
    assert s["design"]["power"]["problems"] == 2 and s["design"]["power"]["pairs"] == 3
    text = render_benchmark(s, {"ert": "e.png", "ecdf": "c.png", "aggregate": "a.png", "profiles": "p.png",
                                "fixed_budget": {}, "convergence": {}, "cd": "d.png"}, "test")
    assert "Power: a Wilcoxon-Holm pair (3 pairs" in text and "needs at least 7 problems" in text
    assert "dz 0.5: 47, dz 0.8: 21, dz 1.2: 11" in text
    assert "Friedman's test over the 3 solvers needs at least" in text
    assert "scipy-sa (one budget)" in text and "and so are they from the ECDFs over budgets" in text
    assert math.isfinite(s["design"]["power"]["problems_needed"][0.8])


# -- the scipy implementations against statsmodels (the core does not install it: issue 41) ------
def test_holm_against_statsmodels_multipletests():
    from statsmodels.stats.multitest import multipletests

    rng = np.random.default_rng(4)
    for p in (rng.uniform(0, 0.2, 7), np.array([0.01, 0.04, 0.04, 0.03, 0.9, 0.01]), np.array([0.3]),
              np.array([1.0, 0.02, 0.02]), rng.uniform(0, 1, 40)):
        assert st.holm(p) == pytest.approx(multipletests(p, method="holm")[1], rel=1e-12, abs=1e-15)
    assert len(st.holm([])) == 0


@pytest.mark.parametrize("n, level", [(5.7, 0.05), (12.0, 0.0167), (30.5, 0.0083)])
def test_paired_t_power_and_its_solutions_against_statsmodels(n, level):
    from statsmodels.stats.power import TTestPower

    t = TTestPower()
    for dz in (0.3, 0.6, 0.8):
        assert st._paired_t_power(dz, n, level) == pytest.approx(t.power(dz, n, level), rel=1e-9)
    # where statsmodels gives nan (scipy's nct.cdf for the lower tail at a large noncentrality,
    # dz 1.5 and n 30.5: nc 8.3), ours stays a probability, above dz 0.8's
    assert st._paired_t_power(0.8, n, level) < st._paired_t_power(1.5, n, level) <= 1.0
    assert st._solve_dz(n, level, 0.8) == pytest.approx(t.solve_power(None, nobs=n, alpha=level, power=0.8), rel=1e-6)
    for dz in st.EFFECTS:
        assert st._solve_n(dz, level, 0.8) == pytest.approx(t.solve_power(dz, nobs=None, alpha=level, power=0.8),
                                                            rel=1e-6)
