"""Suite studies end to end: `femu study --suite`, the benchmark report (`femu report`, `--json`),
ties below the last target, the IOHprofiler export of suite runs, and every built-in at
dimensions 12 and 96 with exact budgets."""

import json
import math
import shutil

import numpy as np
import pytest
from scipy import stats as sps
from statsmodels.stats.multitest import multipletests

import fe_problem as fp
from adapters import available, run
from adapters.budget import min_budget
from adapters.harness import RunResult
from adapters.registry import get
from femu.cli import main
from femu.reports.ioh import FUNCTION_IDS, ioh_terms, read_ioh
from femu.studies.store import Store
from femu.studies.study import run_study

PROBLEMS = ("hframe-freq/12/1", "hframe-freq/12/2")
SOLVERS = ("cma-es", "random-search", "sensitivity")
SEEDS = 3
BUDGET = 300


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path = tmp_path_factory.mktemp("suite") / "store"
    assert main(["study", "--suite", ",".join(PROBLEMS), "--optimizers", ",".join(SOLVERS), "--seeds",
                 f"0-{SEEDS - 1}", "--budget", str(BUDGET), "--store", str(path), "--workers", "0",
                 "--no-progress"]) == 0
    return path


def _report_json(path, capsys) -> dict:
    capsys.readouterr()
    assert main(["report", str(path), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_suite_study_records_carry_the_id_and_f_opt_and_resume(store, capsys):
    runs = Store(store).runs()
    assert len(runs) == len(PROBLEMS) * len(SOLVERS) * SEEDS
    for r in runs:
        assert r.variant == r.problem and r.problem in PROBLEMS
        assert r.f_opt == fp.suite_problem(r.problem).f_opt == 0.0
        assert r.n_evals == BUDGET and r.status == "ok"
    assert (store / "runs" / "hframe-freq+12+1__cma-es__b300__s0.json").exists()
    manifest = json.loads((store / "study.json").read_text())
    assert manifest["suite"] == ",".join(PROBLEMS) and manifest["variants"] == list(PROBLEMS)
    capsys.readouterr()
    assert main(["study", "--suite", ",".join(PROBLEMS), "--optimizers", ",".join(SOLVERS), "--seeds",
                 f"0-{SEEDS - 1}", "--budget", str(BUDGET), "--store", str(store), "--workers", "0",
                 "--no-progress"]) == 0
    out = capsys.readouterr()
    assert f"(0 new, {len(runs)} kept)" in out.out
    # 3 seeds: a Mann-Whitney test reaches p = 2 / C(6, 3) = 0.1 at best, Holm over 6 tests 0.6
    assert "warning: with 3 seed(s) per solver no pairwise test can separate" in out.err and "0.6" in out.err


def test_a_family_or_dimension_prefix_selects_every_problem_under_it(tmp_path):
    result = run_study("random-search", "0", 20, tmp_path / "s", suite="hframe-shape/12", workers=0, progress=False)
    assert sorted(r.problem for r in result.runs) == [f"hframe-shape/12/{k}" for k in range(1, 6)]
    assert all(r.n_evals == 20 and r.f_opt == 0.0 for r in result.runs)
    result = run_study("random-search", "0", 20, tmp_path / "p", suite="paper", variants="synthetic", workers=0,
                       progress=False)
    assert [r.variant for r in result.runs] == ["synthetic", "paper/12/1"]
    assert result.runs[1].f_opt == fp.suite.PAPER_F_OPT and result.runs[0].f_opt is None


def _hits(run: RunResult, f_opt: float, delta: float) -> float:
    """First evaluation at which best J - f_opt <= delta (inf: never), from the stored trace."""
    for n, f in run.trace:
        if f - f_opt <= delta:
            return n
    return math.inf


def test_report_json_targets_ert_and_comparison(store, capsys):
    s = _report_json(store, capsys)
    assert s["solvers"] == sorted(SOLVERS) and s["budget"] == BUDGET
    for p in s["problems"]:
        prob = fp.suite_problem(p["id"])
        gap = float(prob.evaluate(prob.x0)[0]) - prob.f_opt
        t = np.asarray(p["targets"])
        # 51 targets, 5 per decade over 10 decades: COCO's 1e2 ... 1e-8 times the family's fixed scale
        assert gap > 0 and p["target_scale"] == fp.suite.TARGET_SCALE["hframe-freq"] == 1e-4
        assert len(t) == 51 and t[0] == pytest.approx(100 * p["target_scale"], rel=1e-15)
        np.testing.assert_allclose(t[1:] / t[:-1], 10 ** -0.2, rtol=1e-12)
        assert t[-1] == pytest.approx(t[0] * 1e-10, rel=1e-12)
    # ERT recomputed from the records: evaluations until hit (or all) summed / runs that hit
    runs = Store(store).runs()
    targets = {p["id"]: p["targets"] for p in s["problems"]}
    for solver in SOLVERS:
        rs = [r for r in runs if r.optimizer == solver]
        for level in (0, 10, 25):
            hits = np.array([_hits(r, 0.0, targets[r.problem][level]) for r in rs])
            want = np.minimum(hits, BUDGET).sum() / np.isfinite(hits).sum() if np.isfinite(hits).any() else None
            got = s["ert"]["ert"][solver]["hframe-freq/12"][level]
            assert (got is None and want is None) or got == pytest.approx(want)
    # problems as blocks: one value per (solver, problem), recomputed from the records
    c = s["comparisons"]["median_final"]
    assert c["n_blocks"] == len(PROBLEMS) and c["problems"] == list(PROBLEMS) and set(c["mean_ranks"]) == set(SOLVERS)
    table = np.array([[np.median([max(r.best_f, targets[pid][-1]) for r in runs if r.optimizer == so and r.problem == pid])
                       for so in sorted(SOLVERS)] for pid in PROBLEMS])
    assert np.array([c["table"][so] for so in sorted(SOLVERS)]).T == pytest.approx(table)
    fr = sps.friedmanchisquare(*table.T)
    if np.all(table == table[:, :1]):
        assert c["friedman_p"] == 1.0
    else:
        assert c["friedman_p"] == pytest.approx(fr.pvalue)
    assert sum(c["mean_ranks"].values()) == pytest.approx(6.0) and len(c["pairwise"]) == 3
    assert c["cd_test"] == "nemenyi" and c["smallest_p"]["wilcoxon"] == 0.5       # 2 problems: 2 / 2^2
    assert "ert" in s["comparisons"] and s["ert_block_level"] == 25
    # per-problem Mann-Whitney U on the unpaired runs, Holm over 3 pairs x 2 problems
    t = s["per_problem"]["final"]
    assert len(t["pairs"]) == 6 and t["smallest_p"] == pytest.approx(0.1) and t["smallest_p_holm"] == pytest.approx(0.6)
    q = t["pairs"][0]
    x = [max(r.best_f, targets[q["problem"]][-1]) for r in runs if r.optimizer == q["a"] and r.problem == q["problem"]]
    y = [max(r.best_f, targets[q["problem"]][-1]) for r in runs if r.optimizer == q["b"] and r.problem == q["problem"]]
    if len(set(x) | set(y)) > 1:
        assert q["p"] == pytest.approx(sps.mannwhitneyu(x, y, alternative="two-sided").pvalue)
    assert s["design"]["mannwhitneyu_holm"] == pytest.approx(0.6) and s["below_f_opt"] == []
    # the aggregate ECDF and the profiles
    assert set(s["aggregate"]["area"]) == set(SOLVERS) and all(0 <= a <= 1 for a in s["aggregate"]["area"].values())
    assert [p["tolerance"] for p in s["profiles"]] == [1e-1, 1e-3, 1e-5, 1e-7]
    assert all(max(v) <= 1 for p in s["profiles"] for v in p["data"].values())
    fb = {(f["solver"], f["budget"]) for f in s["fixed_budget"]}
    assert fb == {(so, b) for so in SOLVERS for b in (3, 30, BUDGET)}
    assert {c["problem"] for c in s["convergence"]} == set(PROBLEMS)


def test_targets_do_not_depend_on_the_solvers_run(store, tmp_path, capsys):
    only = tmp_path / "one-solver"
    shutil.copytree(store, only)
    for f in (only / "runs").glob("*.json"):
        if "__random-search__" not in f.name:
            f.unlink()
    full, part = _report_json(store, capsys), _report_json(only, capsys)
    assert part["solvers"] == ["random-search"] and part["problems"] == full["problems"]
    assert part["ert"]["ert"]["random-search"] == full["ert"]["ert"]["random-search"]


def test_markdown_report_figures_and_ioh_export(store, tmp_path, capsys):
    out = tmp_path / "rep"
    assert main(["report", str(store), "--out", str(out), "--ioh"]) == 0
    md = (out / "report.md").read_text()
    for heading in ("## Problems", "## Expected running time (ERT)", "## Fixed-target ECDFs",
                    "## Aggregated ECDF over all problems and targets", "## Data and performance profiles",
                    "## Fixed-budget precision", "## Statistical comparison on problems as blocks",
                    "## Per-problem tests on the runs", "## Costs", "## Convergence per problem"):
        assert heading in md
    assert "Smallest p-values this design can reach" in md and "No per-problem Mann-Whitney (more seeds) and no Wilcoxon-Holm" in md
    for png in ("ert.png", "ecdf.png", "cd.png", "aggregate_ecdf.png", "profiles.png", "fixed_budget_hframe-freq_12.png",
                "convergence_hframe-freq_12.png"):
        assert (out / png).stat().st_size > 5000 and f"({png})" in md
    assert json.loads((out / "stats.json").read_text())["problems"][0]["id"] == PROBLEMS[0]
    # IOHprofiler: our function id, the suite instance, raw_y = (J - f_opt) / scale, x in [0, 1]
    back = read_ioh(out / "ioh")
    runs = {(r.optimizer, int(r.problem[-1]), r.seed): r for r in Store(store).runs()}
    assert len(back) == len(runs)
    for b in back:
        r = runs[(b.algorithm, b.instance, int(b.attributes["seed"]))]
        terms = ioh_terms(r.problem)
        assert b.function_id == FUNCTION_IDS["hframe-freq"] and b.dimension == 12
        assert terms.f_opt == 0.0 and terms.scale == 1e-2
        assert terms.objective(b.best_y) == pytest.approx(r.best_f, rel=1e-9)
    marker = json.loads((out / "ioh" / "femu-ioh.json").read_text())
    assert marker["problems"][PROBLEMS[1]]["instance"] == 2 and marker["problems"][PROBLEMS[1]]["f_opt_kind"] == "exact"
    meta = json.loads(next((out / "ioh" / "cma-es").glob("IOHprofiler_*.json")).read_text())
    x = np.array([run["best"]["x"] for sc in meta["scenarios"] for run in sc["runs"]])
    assert x.shape[1] == 12 and np.all((x >= 0) & (x <= 1))


def _record(solver: str, seed: int, trace: list) -> RunResult:
    p = fp.suite_problem(PROBLEMS[0])
    return RunResult(optimizer=solver, problem=PROBLEMS[0], variant=PROBLEMS[0], seed=seed, budget=1000,
                     n_evals=1000, best_f=trace[-1][1], best_x=list(p.truth), trace=trace, f_opt=0.0)


def test_solvers_reaching_f_opt_within_round_off_are_tied(tmp_path, capsys):
    # a and b follow one path, then end 1e-14 and 3e-15 above f_opt = 0 (both below the last
    # target, 1e-12); c stops at 1e-4: a and b tie, both beat c
    store = Store(tmp_path / "ties")
    rng = np.random.default_rng(1)
    n = 8
    a_end = 1e-14 * (1 + rng.random(n))
    for k in range(n):
        start = [[1, 4e-3], [100, 1e-6], [400, 1e-11]]
        store.write(_record("a", k, start + [[700, float(a_end[k])], [1000, float(a_end[k])]]))
        store.write(_record("b", k, start + [[700, 3e-15], [1000, 3e-15]]))
        store.write(_record("c", k, [[1, 4e-3], [500, 1e-4 * (1 + 0.1 * k)], [1000, 1e-4 * (1 + 0.1 * k)]]))
    s = _report_json(store.path, capsys)
    # one problem: no comparison on problems as blocks, said; the per-problem tests tie a and b
    assert s["comparisons"] == {} and "at least 2 common problems" in s["not_compared"]
    for metric in ("auc", "final"):
        pw = {(p["a"], p["b"]): p for p in s["per_problem"][metric]["pairs"]}
        assert pw[("a", "b")]["p"] == 1.0 and pw[("a", "b")]["better"] is None
        assert pw[("a", "c")]["better"] == "a" and pw[("b", "c")]["better"] == "b"
    # final: a's runs all tie at the last target (1e-12), c's are its final values; scipy's test
    # (asymptotic: ties), Holm over the 3 pairs
    pw = {(p["a"], p["b"]): p for p in s["per_problem"]["final"]["pairs"]}
    ref = sps.mannwhitneyu(np.full(n, 1e-12), [1e-4 * (1 + 0.1 * k) for k in range(n)], alternative="two-sided")
    assert pw[("a", "c")]["p"] == pytest.approx(ref.pvalue) and pw[("a", "c")]["statistic"] == 0
    # Holm over the 3 pairs (p, p, 1): 3p for both equal p-values (statsmodels' multipletests)
    assert pw[("a", "c")]["p_holm"] == pytest.approx(multipletests([1.0, ref.pvalue, ref.pvalue], method="holm")[1][1])
    assert pw[("a", "c")]["p_holm"] == pytest.approx(3 * ref.pvalue)
    # on the raw final values a test would separate a and b: the last target is what ties them
    assert sps.wilcoxon(a_end, np.full(n, 3e-15)).pvalue < 0.05


def test_report_and_study_input_errors_are_one_line(store, tmp_path, capsys):
    capsys.readouterr()
    assert main(["report", str(store)]) == 2
    assert "--out DIR" in capsys.readouterr().err
    assert main(["study", "--suite", "hframe-freq/13", "--optimizers", "cma-es", "--seeds", "0", "--budget", "50",
                 "--store", str(tmp_path / "x"), "--workers", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--suite" in err and "'hframe-freq/13' matches no problem" in err
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("pid", ["hframe-freq/12/1", "hframe-freq/96/1"])
def test_every_builtin_spends_its_exact_budget_at_dimensions_12_and_96(pid):
    problem = fp.suite_problem(pid)
    assert {"deap-ga-stock", "nevergrad-ngopt", "optuna-cmaes", "optuna-tpe"} <= set(available())
    for name in available():
        need = min_budget(get(name), problem.n_var)
        # past the first population or batch, and not a whole number of them
        budget = max(2 * need + 7, 47)
        r = run(name, fp.suite_problem(pid), budget, 0)
        assert (r.status, r.n_evals, len(r.best_x)) == ("ok", budget, problem.n_var), (name, r.error)
        if need > 1:  # below its computed minimum the method is refused before it runs
            with pytest.raises(ValueError, match=f"needs a budget of at least {need} evaluations"):
                run(name, fp.suite_problem(pid), need - 1, 0)


def test_a_record_within_rounding_below_f_opt_is_accepted_and_reported(tmp_path, capsys):
    from femu.studies.store import check_record

    store = Store(tmp_path / "rounding")
    for k in range(2):
        # a record of a version that did not clamp 1 - MAC: best J -3e-15 (seen on hframe-shape)
        store.write(_record("a", k, [[1, 4e-3], [600, -3e-15 * (k + 1)]]))
        store.write(_record("b", k, [[1, 4e-3], [900, 1e-5]]))
    s = _report_json(store.path, capsys)
    assert s["below_f_opt"] == [] and s["n_runs"] == 4
    bad = _record("a", 9, [[1, 4e-3], [600, -1e-9]]).to_dict()
    assert "field 'best_f'" in check_record(bad, "hframe-freq+12+1__a__b1000__s9")
