"""Benchmark statistics (femu.reports.stats) on hand-made traces whose answers are known."""

import json
import math

import numpy as np
import pytest

from femu.reports import stats as st
from fe_problem.jsonutil import dumps


def _run(solver, problem, seed, trace, n_evals=1000):
    return st.RunTrace(solver, problem, seed, n_evals, tuple(tuple(t) for t in trace))


def test_targets_are_fixed_by_the_problem_log_spaced_over_ten_decades():
    t = st.fixed_targets("fam/12/1", 1.0e-6, 1.0e-6 + 3.0e-3)
    assert len(t.deltas) == 51
    assert t.deltas[0] == pytest.approx(1e-2) and t.floor == pytest.approx(1e-12)
    ratios = np.array(t.deltas[:-1]) / np.array(t.deltas[1:])
    assert np.allclose(ratios, 10 ** 0.2)
    # an exact power of ten is its own top
    assert st.fixed_targets("p", 0.0, 1e-3).deltas[0] == pytest.approx(1e-3)
    with pytest.raises(ValueError, match="must be above f_opt"):
        st.fixed_targets("p", 1.0, 0.5)


def test_hitting_times_and_ert_of_a_known_case():
    t = st.fixed_targets("p/12/1", 0.0, 5e-3)          # 1e-2 ... 1e-12
    runs = [_run("a", "p/12/1", 0, [[1, 5e-3], [100, 1e-13]]),
            _run("a", "p/12/1", 1, [[1, 5e-3], [50, 1e-6], [200, 5e-13]]),
            _run("a", "p/12/1", 2, [[1, 5e-3], [1000, 1e-5]])]
    h = np.array([st.hitting_times(r, t) for r in runs])
    assert list(h[:, 0]) == [1, 1, 1]                  # 1e-2 hit at the first evaluation
    assert list(h[:, -1]) == [100, 200, math.inf]       # the floor 1e-12
    i6 = t.deltas.index(min(t.deltas, key=lambda d: abs(d - 1e-6)))
    assert list(h[:, i6]) == [100, 50, math.inf]
    # COCO: (100 + 200 + 1000 evaluations of the failed run) / 2 successes
    e = st.ert(h, [1000, 1000, 1000])
    assert e[-1] == pytest.approx(650.0)
    assert e[i6] == pytest.approx((100 + 50 + 1000) / 2)
    table = st.ert_table(runs, {"p/12/1": t})
    assert table.ert["a"]["p/12"][-1] == pytest.approx(650.0)
    assert table.successes["a"]["p/12"][-1] == 2 and table.runs["a"]["p/12"] == 3
    none = st.ert(np.full((2, 1), np.inf), [10, 10])
    assert none[0] == math.inf


def test_ecdf_pools_instances_by_target_level_and_fixed_budget_reads_the_trace():
    targets = {"f/12/1": st.fixed_targets("f/12/1", 0.0, 1e-2), "f/12/2": st.fixed_targets("f/12/2", 1.0, 1.08)}
    runs = [_run("a", "f/12/1", 0, [[1, 1e-2], [10, 1e-12]], n_evals=10),
            _run("a", "f/12/2", 0, [[1, 1.08]], n_evals=10)]   # never improves: hits only level 0
    (e,) = st.ecdfs(runs, targets, grid=[1, 9, 10])
    assert e.group == "f/12" and e.n_runs == 2
    assert e.fraction == pytest.approx((2 / 102, 2 / 102, 52 / 102))
    fb = {(x.budget): x for x in st.fixed_budget(runs, targets, [5, 10])}
    assert fb[5].deltas == pytest.approx((1e-2, 0.08))
    assert fb[10].deltas == pytest.approx((1e-12, 0.08))
    assert fb[10].floor == pytest.approx(1e-12)


def test_holm_on_known_p_values():
    # sorted 0.005, 0.01, 0.03, 0.04 times 4, 3, 2, 1 = 0.02, 0.03, 0.06, 0.04 -> monotone 0.06
    assert st.holm([0.01, 0.04, 0.03, 0.005]) == pytest.approx([0.03, 0.06, 0.06, 0.02])
    assert st.holm([0.5, 0.9]) == pytest.approx([1.0, 1.0])


def test_nemenyi_cd_matches_demsars_table():
    # Demsar (2006), table 5: q_0.05 = 2.343 for k = 3, 2.569 for k = 4
    assert st.nemenyi_cd(3, 10) == pytest.approx(2.343 * math.sqrt(3 * 4 / 60), rel=1e-3)
    assert st.nemenyi_cd(4, 20) == pytest.approx(2.569 * math.sqrt(4 * 5 / 120), rel=1e-3)


def _final_runs(values: dict, f_opt=0.0, problem="p/12/1"):
    """One run per (solver, seed) whose final J is values[solver][seed]."""
    return [_run(s, problem, k, [[1, 1e-2], [1000, f_opt + v]]) for s, vs in values.items() for k, v in enumerate(vs)]


def test_friedman_on_a_known_table_and_mean_ranks():
    # a always best, b second, c worst on 4 blocks: ranks 1, 2, 3; chi2 = 12/(4*3*4) * (4^2 + 8^2 + 12^2) - 3*4*4 = 8
    runs = _final_runs({"a": [1e-8, 2e-8, 3e-8, 4e-8], "b": [1e-6, 2e-6, 3e-6, 4e-6], "c": [1e-4, 2e-4, 3e-4, 4e-4]})
    c = st.compare(runs, {"p/12/1": st.fixed_targets("p/12/1", 0.0, 1e-2)})
    assert c.friedman_statistic == pytest.approx(8.0)
    assert c.friedman_p == pytest.approx(math.exp(-4.0))   # chi2 with 2 dof: exp(-x/2)
    assert c.mean_ranks == pytest.approx({"a": 1.0, "b": 2.0, "c": 3.0})
    assert c.n_blocks == 4 and c.n_dropped_blocks == 0
    # 4 pairs all one way: the exact two-sided Wilcoxon p is 2/16 = 0.125 for each pair
    assert [p.p for p in c.pairwise] == pytest.approx([0.125] * 3)
    assert [p.p_holm for p in c.pairwise] == pytest.approx([0.375] * 3)
    assert all(p.better is None for p in c.pairwise)
    assert c.cliques == (("a", "b", "c"),)


def test_solvers_below_the_final_target_are_tied_and_the_others_separate():
    f_opt = 5.0e-6
    rng = np.random.default_rng(0)
    n = 12
    # a and b both reach f_opt within round-off (1e-14 and 3e-15 above it, and one even below
    # it); c stops 1e-4 above it
    vals = {"a": list(1e-14 * rng.random(n)), "b": [3e-15] * (n - 1) + [-2e-16], "c": list(1e-4 + 1e-5 * rng.random(n))}
    runs = _final_runs(vals, f_opt=f_opt)
    targets = {"p/12/1": st.fixed_targets("p/12/1", f_opt, f_opt + 1e-2)}   # floor 1e-12
    scores = st.run_scores(runs, targets, "final")
    assert np.all(scores[: 2 * n] == pytest.approx(1e-12))
    c = st.compare(runs, targets)
    assert c.mean_ranks["a"] == pytest.approx(1.5) and c.mean_ranks["b"] == pytest.approx(1.5)
    assert c.mean_ranks["c"] == pytest.approx(3.0)
    pw = {(p.a, p.b): p for p in c.pairwise}
    assert pw[("a", "b")].p == 1.0 and pw[("a", "b")].better is None
    assert pw[("a", "c")].better == "a" and pw[("b", "c")].better == "b"
    assert pw[("a", "c")].p_holm <= 0.05
    assert c.cliques == (("a", "b"),)
    # on raw values a and b would differ; the floor is what makes them tie
    assert len(set(vals["a"])) > 1 and vals["a"] != vals["b"]


def test_auc_metric_rewards_earlier_hits_and_ties_equal_runs():
    t = {"p/12/1": st.fixed_targets("p/12/1", 0.0, 1e-2)}
    runs = [_run("fast", "p/12/1", 0, [[1, 1e-2], [10, 1e-13]], 100),
            _run("slow", "p/12/1", 0, [[1, 1e-2], [90, 1e-13]], 100),
            _run("same", "p/12/1", 0, [[1, 1e-2], [10, 1e-14]], 100)]
    s = st.run_scores(runs, t, "auc")
    assert s[0] < s[1] and s[0] == s[2]


def test_blocks_missing_a_solver_are_dropped_and_errors_are_clear():
    t = {"p/12/1": st.fixed_targets("p/12/1", 0.0, 1e-2)}
    runs = _final_runs({"a": [1e-5, 1e-6, 1e-7], "b": [1e-4, 1e-3]})
    c = st.compare(runs, t)
    assert c.n_blocks == 2 and c.n_dropped_blocks == 1
    assert c.friedman_p is None                       # two solvers: no omnibus test
    with pytest.raises(ValueError, match="no targets for problem"):
        st.compare(_final_runs({"a": [1e-5, 1e-6]}, problem="q/1/1") + runs, t)
    with pytest.raises(ValueError, match="at least 2 solvers"):
        st.compare(_final_runs({"a": [1e-5, 1e-6]}), t)
    with pytest.raises(ValueError, match="metric must be one of"):
        st.run_scores(runs, t, "raw")


def test_records_are_strict_json_and_run_traces_come_from_run_records():
    from adapters import harness
    rec = harness.RunResult(optimizer="x", problem="p/12/1", seed=3, budget=20, n_evals=20, best_f=1e-3,
                            trace=[[1, 1e-2], [7, 1e-3], [20, 1e-3]])
    r = st.RunTrace.of(rec)
    assert r == st.RunTrace.of(json.loads(json.dumps(rec.to_dict())))
    assert r.best_at([0, 6, 7, 100]).tolist() == [math.inf, 1e-2, 1e-3, 1e-3]
    t = {"p/12/1": st.fixed_targets("p/12/1", 0.0, 1e-2)}
    runs = [r, st.RunTrace("y", "p/12/1", 3, 20, ((1, 1e-2),)), st.RunTrace("x", "p/12/1", 4, 20, ((1, 1e-4),)),
            st.RunTrace("y", "p/12/1", 4, 20, ((1, 1e-2),))]
    for obj in (st.compare(runs, t), st.ert_table(runs, t), st.ecdfs(runs, t), st.fixed_budget(runs, t, [5]), t):
        json.loads(dumps(obj))   # strict JSON: inf became null
