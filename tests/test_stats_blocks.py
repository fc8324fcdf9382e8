"""Problems as blocks, per-problem tests, ERT ranges, aggregates and profiles (femu.reports.stats),
each checked against scipy / statsmodels or a closed form, on fixtures with ties, a solver that
never hits a target, two solvers only and one problem only."""

import math

import numpy as np
import pytest
from scipy import stats as sps
from statsmodels.stats.multitest import multipletests

from femu.reports import stats as st


def _run(solver, problem, seed, trace, n_evals=1000):
    return st.RunTrace(solver, problem, seed, n_evals, tuple(tuple(t) for t in trace))


def _targets(problems, f_start=1.0, scale=1e-2):
    return {p: st.fixed_targets(p, 0.0, f_start, scale=scale) for p in problems}


def _final(values: dict, problems):
    """values[solver][problem] = list of final J per seed (each run starts at J = 1)."""
    return [_run(s, p, k, [[1, 1.0], [1000, v]]) for s, per in values.items() for p in problems
            for k, v in enumerate(per[p])]


# a table with ties (b = c on p3, all three on p5 below the floor 1e-10) and a solver that never
# reaches a target below 1e-1 (d)
PROBLEMS = ["f/12/1", "f/12/2", "f/12/3", "f/12/4", "f/12/5", "f/12/6"]
VALUES = {
    "a": {"f/12/1": [1e-6, 2e-6, 3e-6], "f/12/2": [1e-5, 1e-5, 2e-5], "f/12/3": [1e-4, 1e-3, 1e-3],
          "f/12/4": [1e-7, 1e-7, 1e-7], "f/12/5": [1e-13, 1e-14, 1e-12], "f/12/6": [3e-3, 4e-3, 5e-3]},
    "b": {"f/12/1": [1e-3, 2e-3, 3e-3], "f/12/2": [1e-6, 1e-6, 2e-6], "f/12/3": [1e-2, 1e-2, 1e-2],
          "f/12/4": [1e-4, 1e-5, 1e-4], "f/12/5": [1e-11, 1e-15, 1e-12], "f/12/6": [1e-2, 1e-2, 1e-2]},
    "c": {"f/12/1": [1e-2, 1e-2, 1e-2], "f/12/2": [1e-2, 1e-2, 2e-2], "f/12/3": [1e-2, 1e-2, 1e-2],
          "f/12/4": [1e-3, 1e-3, 1e-3], "f/12/5": [1e-13, 1e-13, 1e-13], "f/12/6": [1e-1, 1e-1, 2e-1]},
    "d": {p: [0.5, 0.6, 0.7] for p in PROBLEMS},
}


def _expected_table(values, targets, solvers, problems):
    return np.array([[np.median([max(v, targets[p].floor) for v in values[s][p]]) for s in solvers] for p in problems])


def test_block_comparison_matches_scipy_and_statsmodels_with_ties_and_a_solver_that_never_hits():
    targets = _targets(PROBLEMS)
    c = st.compare_problems(_final(VALUES, PROBLEMS), targets, "median_final")
    solvers = ("a", "b", "c", "d")
    table = _expected_table(VALUES, targets, solvers, PROBLEMS)
    assert c.solvers == solvers and c.problems == tuple(PROBLEMS) and c.n_blocks == 6
    assert np.array([c.table[s] for s in solvers]).T == pytest.approx(table)
    assert table[4, 0] == table[4, 2] == targets["f/12/5"].floor          # a tie below the floor
    ranks = sps.rankdata(table, axis=1).mean(axis=0)
    assert [c.mean_ranks[s] for s in solvers] == pytest.approx(ranks)
    fr = sps.friedmanchisquare(*table.T)
    assert (c.friedman_statistic, c.friedman_p) == pytest.approx((fr.statistic, fr.pvalue))
    raw = [sps.wilcoxon(table[:, i], table[:, j], zero_method="zsplit").pvalue
           for i in range(4) for j in range(i + 1, 4)]
    assert [pw.p for pw in c.pairwise] == pytest.approx(raw)
    assert [pw.p_holm for pw in c.pairwise] == pytest.approx(multipletests(raw, method="holm")[1])
    # the CD diagram's cliques come from Nemenyi's test: inside a clique every pair is closer
    # than the CD, and every pair at least the CD apart is in no common clique
    assert c.cd_test == "nemenyi" and c.critical_difference == pytest.approx(st.nemenyi_cd(4, 6))
    for cl in c.cliques:
        assert max(c.mean_ranks[s] for s in cl) - min(c.mean_ranks[s] for s in cl) < c.critical_difference
    for a in solvers:
        for b in solvers:
            if abs(c.mean_ranks[a] - c.mean_ranks[b]) >= c.critical_difference:
                assert not any(a in cl and b in cl for cl in c.cliques)
    assert c.smallest_p["wilcoxon"] == pytest.approx(2 / 2 ** 6)
    assert c.smallest_p["wilcoxon_holm"] == pytest.approx(6 * 2 / 2 ** 6)
    assert c.smallest_p["friedman"] == pytest.approx(sps.chi2.sf(6 * 3, 3))


def test_block_value_ert_at_a_level_and_a_solver_that_never_hits_is_last():
    targets = _targets(PROBLEMS)
    runs = _final(VALUES, PROBLEMS)
    level = 25                                   # 1e-3 x the scale 1e-2: J <= 1e-5
    c = st.compare_problems(runs, targets, "ert", level=level)
    assert "ERT" in c.value_name and str(level) in c.value_name
    for s in "abcd":
        for i, p in enumerate(PROBLEMS):
            hit = [v <= targets[p].deltas[level] for v in VALUES[s][p]]
            expect = 1000 * len(hit) / sum(hit) if any(hit) else math.inf   # every run hits at 1000 or never
            assert c.table[s][i] == pytest.approx(expect)
    assert all(v == math.inf for v in c.table["d"])
    assert c.mean_ranks["d"] == max(c.mean_ranks.values())
    # the signed-rank test sees an infinite ERT as 10 x the largest finite one (ties with infinity)
    table = np.array([c.table[s] for s in "abcd"]).T
    big = 10 * table[np.isfinite(table)].max()
    seen = np.where(np.isfinite(table), table, big)
    raw = [sps.wilcoxon(seen[:, i], seen[:, j], zero_method="zsplit").pvalue if np.any(seen[:, i] != seen[:, j])
           else 1.0 for i in range(4) for j in range(i + 1, 4)]
    assert [pw.p for pw in c.pairwise] == pytest.approx(raw)
    assert [pw.p_holm for pw in c.pairwise] == pytest.approx(multipletests(raw, method="holm")[1])


def test_two_solvers_have_no_friedman_and_one_problem_has_no_block_comparison():
    targets = _targets(PROBLEMS)
    two = {s: VALUES[s] for s in ("a", "b")}
    c = st.compare_problems(_final(two, PROBLEMS), targets)
    table = _expected_table(two, targets, ("a", "b"), PROBLEMS)
    assert c.friedman_p is None and "friedman" not in c.smallest_p
    (pw,) = c.pairwise
    ref = sps.wilcoxon(table[:, 0], table[:, 1], zero_method="zsplit")
    assert (pw.statistic, pw.p, pw.p_holm) == pytest.approx((ref.statistic, ref.pvalue, ref.pvalue))
    with pytest.raises(ValueError, match="at least 2 common problems"):
        st.compare_problems(_final(two, PROBLEMS[:1]), targets)


def test_per_problem_mann_whitney_with_holm_over_pairs_and_problems():
    targets = _targets(PROBLEMS)
    runs = _final(VALUES, PROBLEMS)
    t = st.per_problem_tests(runs, targets, "final")
    expect = []
    for p in PROBLEMS:
        for a, b in [("a", "b"), ("a", "c"), ("a", "d"), ("b", "c"), ("b", "d"), ("c", "d")]:
            x = [max(v, targets[p].floor) for v in VALUES[a][p]]
            y = [max(v, targets[p].floor) for v in VALUES[b][p]]
            if len(set(x) | set(y)) == 1:       # all tied: no evidence (scipy gives nan)
                expect.append((p, a, b, 4.5, 1.0))
            else:
                r = sps.mannwhitneyu(x, y, alternative="two-sided")
                expect.append((p, a, b, r.statistic, r.pvalue))
    assert [(q.problem, q.a, q.b) for q in t.pairs] == [e[:3] for e in expect]
    assert [q.statistic for q in t.pairs] == pytest.approx([e[3] for e in expect])
    assert [q.p for q in t.pairs] == pytest.approx([e[4] for e in expect])
    assert [q.p_holm for q in t.pairs] == pytest.approx(multipletests([e[4] for e in expect], method="holm")[1])
    # 3 runs each: no test can reach 0.05 (2 / C(6, 3) = 0.1), so nothing is separated
    assert t.smallest_p == pytest.approx(0.1) and t.smallest_p_holm == 1.0
    assert all(q.better is None for q in t.pairs)


def test_per_problem_tests_separate_with_enough_runs_on_one_problem():
    targets = _targets(["g/12/1"])
    runs = ([_run("a", "g/12/1", k, [[1, 1.0], [1000, 1e-6 * (k + 1)]]) for k in range(8)]
            + [_run("b", "g/12/1", k, [[1, 1.0], [1000, 1e-3 * (k + 1)]]) for k in range(8)])
    (q,) = st.per_problem_tests(runs, targets, "final").pairs
    ref = sps.mannwhitneyu([1e-6 * (k + 1) for k in range(8)], [1e-3 * (k + 1) for k in range(8)])
    assert q.p == pytest.approx(ref.pvalue) == pytest.approx(2 / math.comb(16, 8))
    assert q.better == "a" and q.statistic == 0


def test_smallest_p_is_what_scipy_gives_at_the_extreme():
    assert st.smallest_p("mannwhitneyu", 5, 5) == pytest.approx(
        sps.mannwhitneyu([1, 2, 3, 4, 5], [6, 7, 8, 9, 10], method="exact").pvalue)
    assert st.smallest_p("wilcoxon", 5) == pytest.approx(sps.wilcoxon([1, 2, 3, 4, 5], method="exact").pvalue)
    assert st.smallest_p("wilcoxon", 5) == 0.0625                      # the 5 seeds
    ranked = np.tile([1.0, 2.0, 3.0], (7, 1))
    assert st.smallest_p("friedman", 7, 3) == pytest.approx(sps.friedmanchisquare(*ranked.T).pvalue)
    assert st.smallest_p("mannwhitneyu", 5, 5, n_tests=9) == pytest.approx(9 * 2 / 252)
    assert not st.seeds_can_separate(5, 3, 3) and st.seeds_can_separate(5, 2, 1)
    assert st.seeds_can_separate(10, 4, 10)


def test_coco_simulated_restarts_mean_is_the_ert_and_ranges_are_run_lengths():
    times = np.array([100.0, np.inf, 300.0, np.inf, 50.0])
    n_evals = np.array([1000, 800, 1000, 1200, 1000])
    e = st.ert(times[:, None], n_evals)[0]
    assert e == pytest.approx((100 + 800 + 300 + 1200 + 50) / 3)
    sims = st.simulated_runlengths(times, n_evals, samples=200_000, seed=1)
    assert sims.mean() == pytest.approx(e, rel=0.01)            # COCO: the expected value is the ERT
    # every sample is a sum of failures' lengths ending with one success
    assert set(np.unique(sims[sims < 800])) <= {50.0, 100.0, 300.0}
    # all runs hit: the samples are the hitting times themselves, the range their percentiles
    lo, hi = st.ert_interval([10.0, 20.0, 30.0, 40.0], [100] * 4, samples=100_000)
    assert (lo, hi) == (10.0, 40.0)
    assert st.ert_interval([np.inf, np.inf], [100, 100]) == (math.inf, math.inf)


def test_ert_table_has_ranges_and_flags_ert_beyond_the_budget():
    targets = {"p/12/1": st.fixed_targets("p/12/1", 0.0, 5e-3)}
    runs = [_run("a", "p/12/1", k, [[1, 5e-3], [900, 1e-13]] if k == 0 else [[1, 5e-3]]) for k in range(4)]
    table = st.ert_table(runs, targets)
    assert table.ert["a"]["p/12"][-1] == pytest.approx(900 + 3000)
    assert table.beyond_budget["a"]["p/12"][-1] and not table.beyond_budget["a"]["p/12"][0]
    assert table.lower["a"]["p/12"][-1] <= table.ert["a"]["p/12"][-1] <= table.upper["a"]["p/12"][-1]
    assert table.lower["a"]["p/12"][-1] >= 900


def test_aggregate_ecdf_and_its_area_against_a_dense_integral():
    targets = {"h/12/1": st.fixed_targets("h/12/1", 0.0, 1.0, scale=1e-2),
               "h/24/1": st.fixed_targets("h/24/1", 0.0, 1.0, scale=1e-2)}
    n_var = {"h/12/1": 12, "h/24/1": 24}
    runs = [_run("a", "h/12/1", 0, [[1, 1.0], [120, 1e-5], [1200, 1e-11]], n_evals=2400),
            _run("a", "h/24/1", 0, [[1, 1.0], [240, 1e-3]], n_evals=2400),
            _run("b", "h/12/1", 0, [[1, 2.0]], n_evals=2400), _run("b", "h/24/1", 0, [[1, 2.0]], n_evals=2400)]
    a = st.aggregate_ecdf(runs, targets, n_var, points=400)
    assert a.lower == pytest.approx(1 / 24) and a.upper == pytest.approx(200)
    assert a.area["b"] == 0.0 and max(a.fraction["b"]) == 0.0
    # the fraction of pairs hit at the end: 1e2 .. 1e-8 on J / 1e-2, problem 1 all 51, problem 2 down to 1e-1 (16)
    assert a.fraction["a"][-1] == pytest.approx((51 / 51 + 16 / 51) / 2)
    # the area: the step function integrated on a dense log grid
    x = np.logspace(math.log10(a.lower), math.log10(a.upper), 200_001)
    def frac(xv):
        out = 0.0
        for pid, r in zip(["h/12/1", "h/24/1"], runs[:2]):
            t = st.hitting_times(r, targets[pid]) / n_var[pid]
            out += (t[None, :] <= xv[:, None]).mean(axis=1) / 2
        return out
    dense = np.trapezoid(frac(x), np.log10(x)) / (np.log10(a.upper) - np.log10(a.lower))
    assert a.area["a"] == pytest.approx(dense, abs=1e-4)


def test_data_and_performance_profiles_of_a_hand_computed_case():
    targets = {p: st.fixed_targets(p, 0.0, 1.0, scale=1e-2) for p in ("k/2/1", "k/2/2")}
    n_var = {"k/2/1": 2, "k/2/2": 2}
    runs = [_run("a", "k/2/1", 0, [[1, 1.0], [30, 1e-4]], n_evals=300),
            _run("a", "k/2/2", 0, [[1, 1.0], [300, 1e-4]], n_evals=300),
            _run("b", "k/2/1", 0, [[1, 1.0], [60, 1e-4]], n_evals=300),
            _run("b", "k/2/2", 0, [[1, 1.0]], n_evals=300)]
    (p,) = st.profiles(runs, targets, n_var, tolerances=(1e-3,))
    assert p.cost == {"a": [30.0, 300.0], "b": [60.0, math.inf]}
    alpha = np.array(p.alpha)
    # data profile: solved within alpha (n_var + 1) = 3 alpha evaluations
    assert p.data["a"] == pytest.approx(((alpha >= 10).astype(float) + (alpha >= 100)) / 2)
    assert p.data["b"] == pytest.approx((alpha >= 20).astype(float) / 2)
    ratio = np.array(p.ratio)
    # performance: a is best on both (ratio 1), b twice a's cost on one, never on the other
    assert p.performance["a"] == pytest.approx(np.ones_like(ratio))
    assert p.performance["b"] == pytest.approx((ratio >= 2).astype(float) / 2)
