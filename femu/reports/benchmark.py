"""The benchmark report of a study: fixed targets on J - f_opt, ERT with COCO's bootstrapped
10-90 % range, fixed-target ECDFs, fixed-budget distributions, convergence per problem, the
comparison of solvers on problems as blocks (Friedman, Wilcoxon-Holm, Nemenyi's critical
difference and its cliques: the CD diagram), per-problem Mann-Whitney U tests on the unpaired
runs (Holm over every pair and problem), the ECDF aggregated over every (problem, target) pair
with its area, data and performance profiles, and the costs of each solver (femu.reports.stats).

Any study gets it: suite problems (`femu study --suite`) with their certified f_opt and their
family's fixed target scale, and problem variants (``paper``: the suite's paper problem;
``synthetic``: f_opt 0, the lower bound J >= 0, targets from the power of ten at or above
J(x0)). The comparisons need at least two solvers on a shared problem (two problems for the
block comparison).

`benchmark_statistics(runs)` computes every number (what `femu report STORE --json` prints);
`write_benchmark(runs, out_dir, source)` renders them as OUT/report.md, OUT/stats.json and the
figures, through femu.reports.render.

Targets depend on the problem only: f_opt, its precision and J(x0) of the problem, rebuilt
from its id (`fe_problem.suite_problem`); a record whose stored f_opt differs from the rebuilt
one was made by another version of the suite and is refused. Where a store holds several
budgets of one (solver, problem, seed), the run with the largest budget counts.
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import lru_cache
from pathlib import Path

import numpy as np

from fe_problem.jsonutil import dumps
from fe_problem.safe_files import write_text
from femu.studies.store import J_ROUNDING
from adapters.variants import USER_PREFIX
from femu.studies.tasks import is_suite_id, variant_stem

#: How f_opt is known for a user's problem (`femu study --model`): the lowest J of the study's
#: runs, not certified.
BEST_KNOWN = "best known"

from . import stats as st
from .render import make_out_dir
from .render import markdown_table, provenance_lines, report_provenance

#: The run scores of the per-problem tests (femu.reports.stats.run_scores).
COMPARISON_METRICS = ("auc", "final")
#: The block values of the comparison on problems, the first drawn as the CD diagram.
BLOCK_VALUES = ("median_final", "ert")
#: The target level of the ``ert`` block value: 5 decades below the top (1e-3 times the scale).
ERT_BLOCK_LEVEL = 5 * st.PER_DECADE
#: Target levels shown in the ERT table: every decade below the top target.
ERT_COLUMNS = tuple(range(0, st.DECADES * st.PER_DECADE + 1, st.PER_DECADE))


@lru_cache(maxsize=None)
def problem_facts(problem_id: str) -> dict:
    """f_opt, how it is known and its precision, the target scale (None: the problem's own
    decade), J(x0), n_var and bounds (Pa) of a suite problem or a variant (built once)."""
    if is_suite_id(problem_id):
        from fe_problem import suite_problem

        p = suite_problem(problem_id)
        f_opt, kind, precision, scale = float(p.f_opt), p.f_opt_kind, p.f_opt_precision, p.target_scale
    else:
        from adapters.variants import make_problem
        from fe_problem.suite import PAPER_F_OPT, PAPER_F_OPT_PRECISION, TARGET_SCALE

        p = make_problem(problem_id)
        if problem_id == "paper":  # the suite's paper problem
            f_opt, kind, precision, scale = PAPER_F_OPT, "certified", PAPER_F_OPT_PRECISION, TARGET_SCALE["paper"]
        elif problem_id.startswith(USER_PREFIX):  # a user's problem: the runs' best J, set by targets_of
            f_opt, kind, precision, scale = None, BEST_KNOWN, None, None
        else:  # J >= 0 is all that is known
            f_opt, kind, precision, scale = 0.0, "lower bound", None, None
    return {"f_opt": f_opt, "f_opt_kind": kind, "f_opt_precision": precision, "target_scale": scale,
            "f_start": float(p.evaluate(p.x0)[0]), "n_var": int(p.n_var), "xl": np.asarray(p.xl, float),
            "xu": np.asarray(p.xu, float), "truth": None if getattr(p, "truth", None) is None else np.asarray(p.truth, float)}


def facts_of(runs) -> dict[str, dict]:
    """{variant: `problem_facts`} of the runs' problems; for a blind instance (its record's
    ``blind``: the truth drawn from its store's secret, femu.studies.blind) the instance's own
    f_opt, how it is known, its precision and J(x0) from its records (which its study made on
    the evaluating side), its truth unknown here; ValueError when its records disagree on them."""
    out: dict[str, dict] = {}
    for r in runs:
        facts = problem_facts(r.variant)
        if not getattr(r, "blind", False):
            out.setdefault(r.variant, facts)
            continue
        if r.f_opt is None or r.f_start is None:  # a run whose process returned nothing: no facts
            continue  # (its instance's come from its other runs; with none, the public one's shape below)
        mine = dict(facts, f_opt=r.f_opt, f_opt_kind=r.f_opt_kind, f_opt_precision=r.f_opt_precision,
                    f_start=r.f_start, truth=None)
        seen = out.setdefault(r.variant, mine)
        if seen["truth"] is not None or any(seen[k] != mine[k] for k in ("f_opt", "f_opt_kind", "f_start")):
            raise ValueError(f"run {r.optimizer} seed {r.seed} on {r.variant}: its blind instance (f_opt "
                             f"{r.f_opt!r}, J(x0) {r.f_start!r}) is not that of the other runs on it (another "
                             "store's secret, or public runs beside blind ones); report one store at a time")
    for r in runs:  # a blind instance whose every run was lost: nothing evaluated, its targets only shown
        out.setdefault(r.variant, problem_facts(r.variant))
    return out


def study_runs(runs) -> list:
    """The runs, one per (solver, problem, seed): the largest budget's."""
    best: dict = {}
    for r in runs:
        key = (r.optimizer, r.variant, r.seed)
        if key not in best or r.budget > best[key].budget:
            best[key] = r
    return [best[k] for k in sorted(best)]


def suite_runs(runs) -> list:
    """The runs on suite problems, one per (solver, problem, seed): the largest budget's."""
    return study_runs([r for r in runs if is_suite_id(r.variant)])


def targets_of(runs) -> dict[str, st.Targets]:
    """The fixed targets of every problem run; ValueError for a record whose f_opt is not the
    suite's (made by another version of the suite)."""
    out, known = {}, facts_of(runs)
    for r in runs:
        if r.variant in out:
            continue
        facts = known[r.variant]
        if facts["f_opt"] is None:  # best known: the lowest J of the study's runs on the problem
            f_opt = min((x.best_f for x in runs if x.variant == r.variant and math.isfinite(x.best_f)),
                        default=facts["f_start"])
            if not f_opt < facts["f_start"]:
                raise ValueError(f"problem {r.variant!r}: no run went below the initial model's J "
                                 f"({facts['f_start']:.6g}; best of the runs {f_opt:.6g}), so there is no best known "
                                 "value to set targets by: run the study with --x0 all or a larger budget")
            out[r.variant] = st.fixed_targets(r.variant, float(f_opt), facts["f_start"], scale=facts["target_scale"])
            continue
        stored = getattr(r, "f_opt", None)
        if stored is not None and not math.isclose(stored, facts["f_opt"], rel_tol=1e-9, abs_tol=1e-15):
            raise ValueError(f"run {r.optimizer} seed {r.seed} on {r.variant}: its record's f_opt {stored!r} is not "
                             f"the suite's {facts['f_opt']!r} (made by another version of the suite); use a new store")
        out[r.variant] = st.fixed_targets(r.variant, facts["f_opt"], facts["f_start"], scale=facts["target_scale"])
    return dict(sorted(out.items()))


def below_f_opt(runs) -> list[dict]:
    """Runs that ended below f_opt by more than its stated precision: each would show that
    f_opt is not the minimum. Empty for an honest store and a true f_opt. The allowance is the
    instance's own `f_opt_precision` (a certificate's is at least J's rounding and noise there,
    docs/suite.md), nothing more; an exact f_opt (0, precision 0) allows only what the store
    accepts below 0 (`J_ROUNDING`: the rounding of 1 - MAC in records made before J was clamped)."""
    out, known = [], facts_of(runs)
    for r in runs:
        facts = known[r.variant]
        allowed = facts["f_opt_precision"] or 0.0
        if facts["f_opt_kind"] == "exact":
            allowed = max(allowed, J_ROUNDING)
        if facts["f_opt_kind"] in ("exact", "certified") and r.best_f is not None and r.best_f < facts["f_opt"] - allowed:
            out.append({"optimizer": r.optimizer, "problem": r.variant, "seed": r.seed, "best_f": r.best_f,
                        "f_opt": facts["f_opt"], "precision": facts["f_opt_precision"]})
    return out


def design(runs, alpha: float = 0.05) -> dict:
    """The smallest p-values the study's design can reach: Mann-Whitney per problem (the fewest
    runs of a solver on a problem), after Holm over every pair and problem, and the block tests
    on the problems every solver ran."""
    solvers = sorted({r.optimizer for r in runs})
    problems = sorted({r.variant for r in runs})
    counts = {}
    for r in runs:
        counts[(r.variant, r.optimizer)] = counts.get((r.variant, r.optimizer), 0) + 1
    shared = [p for p in problems if all((p, s) in counts for s in solvers)]
    n_pairs = sum(math.comb(sum((p, s) in counts for s in solvers), 2) for p in problems)
    fewest = min(counts.values()) if counts else 0
    out = {"alpha": alpha, "solvers": len(solvers), "problems": len(problems), "shared_problems": len(shared),
           "fewest_runs": fewest, "per_problem_tests": n_pairs}
    if n_pairs and fewest:
        out["mannwhitneyu"] = st.smallest_p("mannwhitneyu", fewest, fewest)
        out["mannwhitneyu_holm"] = st.smallest_p("mannwhitneyu", fewest, fewest, n_tests=n_pairs)
    if len(solvers) >= 2 and len(shared) >= 2:
        out["wilcoxon_holm"] = st.smallest_p("wilcoxon", len(shared), n_tests=math.comb(len(solvers), 2))
        if len(solvers) >= 3:
            out["friedman"] = st.smallest_p("friedman", len(shared), len(solvers))
    if len(solvers) >= 2:  # what a comparison on the problems can detect, and how many it needs
        out["power"] = st.wilcoxon_power(len(shared), math.comb(len(solvers), 2), alpha)
        if len(solvers) >= 3:
            out["friedman_min_problems"] = st.min_blocks("friedman", alpha, k=len(solvers))
    return out


def fixed_budgets(max_budget: int) -> list[int]:
    """The budgets of the fixed-budget view: 1 %, 10 % and 100 % of the largest budget."""
    return sorted({max(1, max_budget // 100), max(1, max_budget // 10), int(max_budget)})


def costs(runs) -> dict:
    """Per solver: median evaluations, and median CPU seconds of the FE and of the optimizer
    (record fields fe_cpu_s / opt_cpu_s; records without them fall back to the wall times
    fe_s and wall_s - fe_s, marked ``"clock": "wall"``)."""
    out = {}
    for solver in sorted({r.optimizer for r in runs}):
        rs = [r for r in runs if r.optimizer == solver]
        cpu = all(getattr(r, "fe_cpu_s", None) is not None and getattr(r, "opt_cpu_s", None) is not None for r in rs)
        fe = [r.fe_cpu_s if cpu else r.fe_s for r in rs]
        opt = [r.opt_cpu_s if cpu else r.wall_s - r.fe_s for r in rs]
        out[solver] = {"runs": len(rs), "median_evals": float(np.median([r.n_evals for r in rs])),
                       "median_fe_s": float(np.median(fe)), "median_opt_s": float(np.median(opt)),
                       "clock": "cpu" if cpu else "wall",
                       "statuses": {s: sum(r.status == s for r in rs) for s in sorted({r.status for r in rs})}}
    return out


def not_anytime(runs) -> dict[str, int]:
    """{solver: its smallest run budget} for the solvers that are not anytime: their record's
    capabilities say so, or (records written before capabilities were recorded) the optimizer's
    class does not declare anytime = True, or cannot be loaded. Their best-so-far below the
    budget is not what a run of that budget would find (the schedule follows the budget)."""
    from adapters.capabilities import capabilities
    from adapters.registry import get

    out: dict[str, int] = {}
    for r in runs:
        caps = getattr(r, "capabilities", None) or {}
        if "anytime" in caps:
            anytime = bool(caps["anytime"])
        else:
            try:
                anytime = capabilities(get(r.optimizer))["anytime"]
            except ValueError:
                anytime = False
        if not anytime:
            out[r.optimizer] = min(out.get(r.optimizer, r.budget), r.budget)
    return dict(sorted(out.items()))


def first_levels(targets: dict[str, st.Targets]) -> dict[str, int]:
    """{group: the first target level below J(x0) - f_opt of every instance of the group}: the
    levels above are reached by the initial model itself (at evaluation 1 by any solver that
    starts there), and the ECDFs start below them."""
    out: dict[str, int] = {}
    for pid, t in targets.items():
        gap = t.f_start - t.f_opt
        k = next((i for i, d in enumerate(t.deltas) if d < gap), len(t.deltas) - 1)
        g = st.group_of(pid)
        out[g] = max(out.get(g, 0), k)
    return dict(sorted(out.items()))


def one_budget_reached(traces, targets: dict[str, st.Targets], one_budget: dict[str, int]) -> dict:
    """{solver: {group: fraction of (run, target) pairs reached at the end of the run}} for the
    solvers that are not anytime: their one honest point of an ECDF."""
    out: dict = {}
    for (solver, group), rs in st.by_key([t for t in traces if t.solver in one_budget],
                                         lambda r: (r.solver, st.group_of(r.problem))).items():
        times = np.concatenate([st.hitting_times(r, targets[r.problem]) for r in rs])
        out.setdefault(solver, {})[group] = float(np.isfinite(times).mean())
    return out


def benchmark_statistics(runs) -> dict:
    """Every number of the benchmark report of `runs` (RunResults, suite problems or variants):
    problems and targets, ERT per solver, group and target level with its bootstrapped range,
    ECDFs, fixed-budget distributions, the comparisons on problems as blocks, the per-problem
    tests, the aggregated ECDF, the profiles, the design's smallest p-values and the costs.
    ValueError when there are no runs."""
    runs = study_runs(runs)
    if not runs:
        raise ValueError("no runs to report on")
    targets = targets_of(runs)
    blind = {r.variant for r in runs if getattr(r, "blind", False)}
    traces = [st.RunTrace(r.optimizer, r.variant, r.seed, r.n_evals, tuple(tuple(t) for t in r.trace))
              for r in runs]
    n_var = {pid: problem_facts(pid)["n_var"] for pid in targets}
    budgets = fixed_budgets(max(r.budget for r in runs))
    one_budget = not_anytime(runs)
    # a solver that is not anytime has no honest value below its budget: left out
    fixed = [fb for fb in st.fixed_budget(traces, targets, budgets)
             if fb.solver not in one_budget or fb.budget >= one_budget[fb.solver]]
    # the anytime aggregates (ECDFs over budgets, the aggregated ECDF, the profiles, the ERT
    # figure) are of the anytime solvers only (of all when none is), on the target levels
    # below every instance's start (`first_levels`)
    anytime = [t for t in traces if t.solver not in one_budget] or traces
    first = first_levels(targets)
    below = {pid: replace(t, deltas=t.deltas[first[st.group_of(pid)]:]) for pid, t in targets.items()}
    comparisons, not_compared = {}, None
    for value in BLOCK_VALUES:
        try:
            comparisons[value] = st.compare_problems(traces, targets, value, level=ERT_BLOCK_LEVEL)
        except ValueError as exc:
            not_compared = str(exc)
    per_problem = {m: st.per_problem_tests(traces, targets, m) for m in COMPARISON_METRICS}
    known = facts_of(runs)
    problems = [{"id": pid, "n_var": n_var[pid], "f_opt": t.f_opt, "f_opt_kind": known[pid]["f_opt_kind"],
                 "f_opt_precision": known[pid]["f_opt_precision"], "blind": pid in blind,
                 "target_scale": known[pid]["target_scale"], "f_start": t.f_start, "targets": t.deltas}
                for pid, t in targets.items()]
    return {"format": "femu.benchmark/2", "solvers": sorted({r.optimizer for r in runs}),
            "budget": max(r.budget for r in runs), "n_runs": len(runs), "problems": problems,
            "target_levels": list(st.target_levels()),
            "ert": st.ert_table(traces, targets), "ert_block_level": ERT_BLOCK_LEVEL,
            "ecdf": st.ecdfs(anytime, below), "first_levels": first,
            "anytime_aggregates": sorted({t.solver for t in anytime}),
            "one_budget_reached": one_budget_reached(traces, below, one_budget),
            "fixed_budget": fixed, "one_budget": one_budget, "comparisons": comparisons,
            "not_compared": not_compared if not comparisons else None, "per_problem": per_problem,
            "design": design(runs), "below_f_opt": below_f_opt(runs),
            "aggregate": st.aggregate_ecdf(anytime, below, n_var), "profiles": st.profiles(anytime, targets, n_var),
            "costs": costs(runs), "convergence": convergence(traces, targets),
            "provenance": report_provenance(runs)}


def convergence(traces, targets, points: int = 40) -> list[dict]:
    """Per problem and solver: median and quartiles of J - f_opt (floored at the problem's
    precision floor) on a log grid of evaluations."""
    grid = st.budget_grid(max(t.n_evals for t in traces), per_decade=12)
    out = []
    for (pid, solver), rs in st.by_key(traces, lambda r: (r.problem, r.solver)).items():
        t = targets[pid]
        d = np.maximum(np.array([r.best_at(grid) for r in rs]) - t.f_opt, t.floor)
        q1, med, q3 = np.percentile(d, [25, 50, 75], axis=0)
        out.append({"problem": pid, "solver": solver, "evals": grid.tolist(), "median": med.tolist(),
                    "q1": q1.tolist(), "q3": q3.tolist(), "runs": len(rs)})
    return out


# -- rendering -------------------------------------------------------------------------------

def _g(x) -> str:
    return "inf" if x is None or not math.isfinite(x) else f"{x:.3g}"


def _ert_lines(s: dict) -> list[str]:
    table = s["ert"]
    levels = [table.levels[i] for i in ERT_COLUMNS]
    out = []
    for group in sorted({g for per in table.ert.values() for g in per}):
        rows = []
        for solver, per in table.ert.items():
            if group in per:
                cells = []
                for i in ERT_COLUMNS:
                    mark = " (beyond budget)" if table.beyond_budget[solver][group][i] else ""
                    rng = (f" [{_g(table.lower[solver][group][i])}, {_g(table.upper[solver][group][i])}]"
                           if math.isfinite(per[group][i]) else "")
                    cells.append(f"{_g(per[group][i])}{rng}{mark} ({table.successes[solver][group][i]}/"
                                 f"{table.runs[solver][group]})")
                rows.append([solver + (" (one budget)" if solver in s.get("one_budget", {}) else "")] + cells)
        out += [f"**{group}**: ERT in FE evaluations [10 %, 90 % of COCO's bootstrapped run lengths with restarts] "
                "(runs that hit / runs) per target; *beyond budget*: the ERT exceeds every run's budget (an "
                "extrapolation from restarts no run made)", ""]
        out += markdown_table(["solver"] + [f"top x 1e-{-round(math.log10(v))}" if v < 1 else "top" for v in levels], rows)
        out.append("")
    return out


def _fixed_budget_lines(s: dict) -> list[str]:
    rows = {}
    for fb in s["fixed_budget"]:
        q1, med, q3 = fb.quartiles
        rows.setdefault((fb.group, fb.solver), {})[fb.budget] = f"{_g(med)} [{_g(q1)}, {_g(q3)}]"
    budgets = sorted({fb.budget for fb in s["fixed_budget"]})
    one = s.get("one_budget", {})
    blank = lambda so, b: "not anytime" if so in one and b < one[so] else ""  # noqa: E731
    return markdown_table(["group", "solver"] + [f"after {b}" for b in budgets],
                          [[g, so] + [v.get(b, blank(so, b)) for b in budgets] for (g, so), v in sorted(rows.items())])


def _one_budget_lines(s: dict) -> list[str]:
    """The note on solvers whose curves are from one budget (not anytime)."""
    one = s.get("one_budget", {})
    if not one:
        return []
    names = ", ".join(f"`{k}` (budget {b})" for k, b in one.items())
    kept_out = set(one) - set(s.get("anytime_aggregates", one))
    reached = s.get("one_budget_reached", {})
    lines = [f"Not anytime: {names}. Their schedule follows the budget (`femu optimizers` lists each "
             "optimizer's capabilities), so their convergence curves and ERT below the budget are from one "
             "budget's runs, not what runs of a smaller budget would find (marked *one budget* in the ERT tables); "
             "their fixed-budget values below it are left out"
             + (", and so are they from the ECDFs over budgets, the aggregated ECDF, the profiles and the ERT figure"
                if kept_out else "") + ".", ""]
    if reached:
        lines += ["Their one honest ECDF point: the fraction of (run, target) pairs reached at the end of the budget.", ""]
        lines += markdown_table(["solver", "budget"] + sorted({g for per in reached.values() for g in per}),
                                [[k, one[k]] + [f"{per.get(g, float('nan')):.3f}" for g in
                                                sorted({g for per in reached.values() for g in per})]
                                 for k, per in reached.items()]) + [""]
    return lines


def _comparison_lines(c: st.BlockComparison) -> list[str]:
    ranks = sorted(c.mean_ranks.items(), key=lambda kv: (kv[1], kv[0]))
    lim = c.smallest_p
    out = [f"**`{c.value}`**: {c.value_name}, one value per (solver, problem), on {c.n_blocks} problems as blocks "
           f"({c.n_dropped_problems} dropped: not run by every solver). "
           + (f"Friedman chi2 = {c.friedman_statistic:.3g}, p = {c.friedman_p:.3g} (smallest reachable "
              f"{lim['friedman']:.2g}); " if c.friedman_p is not None else "two solvers, no omnibus test; ")
           + f"Nemenyi CD = {c.critical_difference:.2f} (alpha {c.alpha}); Wilcoxon signed-rank on the problems, Holm "
           f"over {len(c.pairwise)} pairs (smallest reachable p {lim['wilcoxon_holm']:.2g}).", ""]
    out += markdown_table(["solver", "mean rank", "Nemenyi clique"],
                          [[k, f"{v:.2f}", ", ".join(str(i + 1) for i, cl in enumerate(c.cliques) if k in cl) or "-"]
                           for k, v in ranks]) + [""]
    out += markdown_table(["a", "b", "Wilcoxon W", "p", "p (Holm)", "better (p Holm <= alpha)"],
                          [[p.a, p.b, f"{p.statistic:.3g}", f"{p.p:.3g}", f"{p.p_holm:.3g}", p.better or "-"]
                           for p in c.pairwise])
    return out + [""]


def _per_problem_lines(t: st.ProblemTests) -> list[str]:
    hits = [p for p in t.pairs if p.better is not None]
    out = [f"**`{t.metric}`**: {len(t.pairs)} Mann-Whitney U tests (every pair on every problem, runs unpaired), Holm "
           f"over all of them; smallest reachable p {t.smallest_p:.2g} per test, {t.smallest_p_holm:.2g} after Holm. "
           f"{len(hits)} separated at alpha {t.alpha}" + (":" if hits else "."), ""]
    if hits:
        out += markdown_table(["problem", "a", "b", "runs", "U", "p", "p (Holm)", "better"],
                              [[p.problem, p.a, p.b, f"{p.n_a}/{p.n_b}", f"{p.statistic:.3g}", f"{p.p:.3g}",
                                f"{p.p_holm:.3g}", p.better] for p in hits]) + [""]
    return out


def _design_lines(d: dict) -> list[str]:
    parts = []
    if "mannwhitneyu_holm" in d:
        parts.append(f"a per-problem Mann-Whitney test with {d['fewest_runs']} runs per solver reaches p >= "
                     f"{d['mannwhitneyu']:.2g}, {d['mannwhitneyu_holm']:.2g} after Holm over {d['per_problem_tests']} tests")
    if "wilcoxon_holm" in d:
        parts.append(f"on {d['shared_problems']} shared problems a Wilcoxon-Holm pair reaches p >= {d['wilcoxon_holm']:.2g}"
                     + (f" and Friedman p >= {d['friedman']:.2g}" if "friedman" in d else ""))
    if not parts:
        return ["No pairwise test is possible: fewer than two solvers on a shared problem.", ""]
    names = {"mannwhitneyu_holm": "per-problem Mann-Whitney (more seeds)",
             "wilcoxon_holm": "Wilcoxon-Holm on the problems (more problems)"}
    weak = [names[k] for k in names if k in d and d[k] > d["alpha"]]
    return ["Smallest p-values this design can reach: " + "; ".join(parts) + "."
            + (f" **No {' and no '.join(weak)} test can separate two solvers at alpha {d['alpha']}.**"
               if weak else ""), ""] + _power_lines(d)


def _power_lines(d: dict) -> list[str]:
    """The power statement of the comparison on problems as blocks (`stats.wilcoxon_power`)."""
    w = d.get("power")
    if not w:
        return []
    now = (f"with these {w['problems']} shared problems it detects, with power {w['power']:.0%}, a standardized "
           f"per-problem difference dz >= {w['detectable_dz']:.2f} (mean over sd of the pair's differences)"
           if w["detectable_dz"] is not None else f"these {w['problems']} shared problems are too few for any")
    need = ", ".join(f"dz {k:g}: {v}" for k, v in w["problems_needed"].items())
    fried = (f"; Friedman's test over the {d['solvers']} solvers needs at least {d['friedman_min_problems']} problems"
             if "friedman_min_problems" in d else "")
    return [f"Power: a Wilcoxon-Holm pair ({w['pairs']} pairs, Holm's first step at alpha {w['level']:.3g}) needs at "
            f"least {w['min_problems']} problems to be separable at all; {now}. Problems needed for power "
            f"{w['power']:.0%} at a given dz (normal differences; Wilcoxon as {st.WILCOXON_ARE:.3f} times the "
            f"paired t-test's problems): {need}{fried}.", ""]


def _aggregate_lines(s: dict) -> list[str]:
    a = s["aggregate"]
    rows = sorted(a.area.items(), key=lambda kv: -kv[1])
    return (["Per solver, the fraction of (problem, target) pairs reached (runs averaged per problem, problems "
             "weighted equally) against FE evaluations / dimension, and the area under it on a log scale from "
             f"{a.lower:.3g} to {a.upper:.3g} evaluations per dimension (1: every target at once; COCO's and "
             "IOHanalyzer's aggregated ECDF).", ""]
            + markdown_table(["solver", "ECDF area"], [[k, f"{v:.3f}"] for k, v in rows]) + [""])


def render_benchmark(s: dict, figures: dict, source: str) -> str:
    """The Markdown of the benchmark report from `benchmark_statistics` and the figure names."""
    lines = [f"# Benchmark report: {', '.join(s['solvers'])}", "",
             f"{s['n_runs']} runs from {source}, budget {s['budget']} FE evaluations. Targets: J - f_opt at "
             f"{len(s['target_levels'])} levels, {st.PER_DECADE} per decade over {st.DECADES} decades: COCO's "
             "1e2 ... 1e-8 times the family's fixed target scale (the same on every instance; docs/suite.md), or "
             "from the power of ten at or above J(x0) - f_opt for a variant without one. Values below the last "
             "target are ties.", ""]
    lines += _design_lines(s["design"])
    if s["below_f_opt"]:
        lines += [f"**{len(s['below_f_opt'])} run(s) ended below f_opt by more than its precision**: "
                  + ", ".join(f"{b['optimizer']} seed {b['seed']} on {b['problem']} ({b['best_f']:.17g} < "
                              f"{b['f_opt']:.17g})" for b in s["below_f_opt"]), ""]
    lines += ["## Problems", ""]
    lines += markdown_table(["id", "n_var", "f_opt", "known as", "precision", "target scale", "J(x0)", "top target",
                             "last target"],
                            [[p["id"] + (" (blind)" if p.get("blind") else ""), p["n_var"], f"{p['f_opt']:.17g}",
                              p["f_opt_kind"],
                              "-" if p["f_opt_precision"] is None else f"{p['f_opt_precision']:.2g}",
                              "own decade" if p["target_scale"] is None else f"{p['target_scale']:.3g}",
                              f"{p['f_start']:.4g}", _g(p["targets"][0]), _g(p["targets"][-1])] for p in s["problems"]])
    if any(p.get("blind") for p in s["problems"]):
        lines += ["", "(blind): the instance's hidden truth and data were drawn from its store's secret, not from its "
                      "id (`femu study --blind`, docs/plugins.md); its f_opt and J(x0) are its own, from its records."]
    best_known = [p["id"] for p in s["problems"] if p["f_opt_kind"] == BEST_KNOWN]
    if best_known:
        lines += ["", f"f_opt of {', '.join(best_known)} is the best J seen over this study's runs (a user's "
                      "problem, `femu study --model`): best known, **not certified**; a better optimum would move "
                      "every target, and a run that reached it only counts as the best of these runs."]
    lines += [""] + _one_budget_lines(s)
    lines += ["## Expected running time (ERT)", ""] + _ert_lines(s)
    first = s.get("first_levels", {})
    lines += [f"![ERT]({figures['ert']})", "", "## Fixed-target ECDFs (instances pooled)", "",
              "The ECDFs (here and aggregated) count the target levels below every instance's J(x0) - f_opt "
              "(the initial model reaches the others at evaluation 1): from level "
              + ", ".join(f"{k} on {g}" for g, k in first.items()) + " of 0 ... 50.", "",
              f"![ECDF]({figures['ecdf']})", "", "## Aggregated ECDF over all problems and targets", ""]
    lines += _aggregate_lines(s) + [f"![aggregated ECDF]({figures['aggregate']})", "",
                                    "## Data and performance profiles", "",
                                    "Moré-Wild data profiles (fraction of problems solved within alpha (n_var + 1) "
                                    "evaluations) and Dolan-Moré performance profiles (fraction of problems whose "
                                    "cost is within a ratio of the best solver's), solved meaning J <= f_opt + tau "
                                    "(J(x0) - f_opt), the cost a solver's ERT on the problem.", "",
                                    f"![profiles]({figures['profiles']})", "",
                                    "## Fixed-budget precision: median [q1, q3] of J - f_opt", ""]
    lines += _fixed_budget_lines(s) + [""] + [f"![fixed budget {g}]({f})" for g, f in figures["fixed_budget"].items()]
    lines += ["", "## Statistical comparison on problems as blocks", "",
              "One value per (solver, problem): seeds are never paired across solvers (they are independent "
              "draws). Friedman's test, Nemenyi's critical difference (two solvers differ when their mean ranks "
              "differ by at least the CD: the CD diagram's bars and cliques both come from it) and, beside it, "
              "Wilcoxon signed-rank tests on the problems with Holm's correction (Demsar 2006).", ""]
    for c in s["comparisons"].values():
        lines += _comparison_lines(c)
    if s["comparisons"]:
        lines += [f"![critical difference]({figures['cd']})", ""]
    else:
        lines += [f"No comparison on problems as blocks: {s['not_compared']}", ""]
    lines += ["## Per-problem tests on the runs", "",
              "Scores per run: `auc` = the fraction of (target, budget) pairs not reached, `final` = final J - f_opt "
              "raised to the last target (ties below it).", ""]
    for t in s["per_problem"].values():
        lines += _per_problem_lines(t)
    lines += ["## Costs (medians per run)", ""]
    lines += markdown_table(["solver", "runs", "evaluations", "FE s", "optimizer s", "clock", "statuses"],
                            [[k, c["runs"], f"{c['median_evals']:.0f}", f"{c['median_fe_s']:.3g}",
                              f"{c['median_opt_s']:.3g}", c["clock"],
                              ", ".join(f"{n} {st_}" for st_, n in c["statuses"].items())]
                             for k, c in s["costs"].items()])
    lines += ["", "## Convergence per problem", ""] + [f"![convergence {g}]({f})" for g, f in figures["convergence"].items()]
    lines += [""] + provenance_lines(s["provenance"])
    return "\n".join(lines) + "\n"


def write_benchmark(runs, out_dir, source: str, name: str = "report.md") -> Path:
    """Write OUT/<name> (report.md), OUT/stats.json and the figures of the runs; returns its path."""
    from . import stats_figures as sf

    s = benchmark_statistics(runs)
    out = make_out_dir(out_dir)
    groups = sorted({st.group_of(p["id"]) for p in s["problems"]})
    keep = set(s["anytime_aggregates"])
    ert_anytime = replace(s["ert"], **{f: {k: v for k, v in getattr(s["ert"], f).items() if k in keep}
                                       for f in ("ert", "successes", "runs", "lower", "upper", "beyond_budget")})
    figures = {"ert": sf.plot_ert(ert_anytime, out / "ert.png").name,
               "ecdf": sf.plot_ecdf(s["ecdf"], out / "ecdf.png").name,
               "aggregate": sf.plot_aggregate(s["aggregate"], out / "aggregate_ecdf.png").name,
               "profiles": sf.plot_profiles(s["profiles"], out / "profiles.png").name,
               "fixed_budget": {g: sf.plot_fixed_budget(s["fixed_budget"], g, out / f"fixed_budget_{_stem(g)}.png").name
                                for g in groups},
               "convergence": {g: sf.plot_convergence([c for c in s["convergence"] if st.group_of(c["problem"]) == g],
                                                      out / f"convergence_{_stem(g)}.png").name for g in groups}}
    if s["comparisons"]:
        figures["cd"] = sf.plot_cd(s["comparisons"][BLOCK_VALUES[0]] if BLOCK_VALUES[0] in s["comparisons"]
                                   else next(iter(s["comparisons"].values())), out / "cd.png").name
    write_text(out / "stats.json", dumps(s) + "\n")
    path = out / name
    write_text(path, render_benchmark(s, figures, source))
    return path


def _stem(group: str) -> str:
    return variant_stem(group)
