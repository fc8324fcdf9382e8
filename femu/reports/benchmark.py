"""The benchmark report of a suite study (runs whose variant is a suite id, `femu study --suite`):
fixed targets on J - f_opt, ERT, fixed-target ECDFs, fixed-budget distributions, convergence
per problem, Friedman + pairwise Wilcoxon-Holm + critical-difference diagram (femu.reports.stats),
and the costs of each solver.

`benchmark_statistics(runs)` computes every number (what `femu report STORE --json` prints);
`write_benchmark(runs, out_dir, source)` renders them as OUT/report.md, OUT/stats.json and the
figures, through femu.reports.render.

Targets depend on the problem only: f_opt and J(x0) of the suite problem, rebuilt from its id
(`fe_problem.suite_problem`); a record whose stored f_opt differs from the rebuilt one was made
by another version of the suite and is refused. Where a store holds several budgets of one
(solver, problem, seed), the run with the largest budget counts.
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

import numpy as np

from fe_problem.jsonutil import dumps
from fe_problem.safe_files import write_text
from femu.studies.tasks import is_suite_id

from . import stats as st
from .render import make_out_dir
from .render import markdown_table

#: The comparison metrics, the first drawn as the CD diagram (femu.reports.stats.run_scores).
COMPARISON_METRICS = ("auc", "final")
#: Target levels shown in the ERT table: every decade below the top target.
ERT_COLUMNS = tuple(range(0, st.DECADES * st.PER_DECADE + 1, st.PER_DECADE))


@lru_cache(maxsize=None)
def problem_facts(problem_id: str) -> dict:
    """f_opt, how it is known, J(x0), n_var and bounds (Pa) of a suite problem (built once)."""
    from fe_problem import suite_problem

    p = suite_problem(problem_id)
    return {"f_opt": float(p.f_opt), "f_opt_kind": p.f_opt_kind, "f_start": float(p.evaluate(p.x0)[0]),
            "n_var": int(p.n_var), "xl": np.asarray(p.xl, float), "xu": np.asarray(p.xu, float),
            "truth": None if p.truth is None else np.asarray(p.truth, float)}


def suite_runs(runs) -> list:
    """The runs on suite problems, one per (solver, problem, seed): the largest budget's."""
    best: dict = {}
    for r in runs:
        if is_suite_id(r.variant):
            key = (r.optimizer, r.variant, r.seed)
            if key not in best or r.budget > best[key].budget:
                best[key] = r
    return [best[k] for k in sorted(best)]


def targets_of(runs) -> dict[str, st.Targets]:
    """The fixed targets of every problem run; ValueError for a record whose f_opt is not the
    suite's (made by another version of the suite)."""
    out = {}
    for r in runs:
        if r.variant in out:
            continue
        facts = problem_facts(r.variant)
        stored = getattr(r, "f_opt", None)
        if stored is not None and not math.isclose(stored, facts["f_opt"], rel_tol=1e-9, abs_tol=1e-15):
            raise ValueError(f"run {r.optimizer} seed {r.seed} on {r.variant}: its record's f_opt {stored!r} is not "
                             f"the suite's {facts['f_opt']!r} (made by another version of the suite); use a new store")
        out[r.variant] = st.fixed_targets(r.variant, facts["f_opt"], facts["f_start"])
    return dict(sorted(out.items()))


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


def benchmark_statistics(runs) -> dict:
    """Every number of the benchmark report of the suite runs among `runs` (RunResults):
    problems and targets, ERT per solver, group and target level, ECDFs, fixed-budget
    distributions, the comparisons (Friedman, pairwise Wilcoxon-Holm, mean ranks, CD) and the
    costs. ValueError when no run is on a suite problem."""
    runs = suite_runs(runs)
    if not runs:
        raise ValueError("no runs on suite problems (femu study --suite ...) to report on")
    targets = targets_of(runs)
    traces = [st.RunTrace(r.optimizer, r.variant, r.seed, r.n_evals, tuple(tuple(t) for t in r.trace))
              for r in runs]
    budgets = fixed_budgets(max(r.budget for r in runs))
    comparisons, not_compared = {}, None
    for metric in COMPARISON_METRICS:
        try:
            comparisons[metric] = st.compare(traces, targets, metric)
        except ValueError as exc:
            not_compared = str(exc)
    problems = [{"id": pid, "n_var": problem_facts(pid)["n_var"], "f_opt": t.f_opt,
                 "f_opt_kind": problem_facts(pid)["f_opt_kind"], "f_start": t.f_start, "targets": t.deltas}
                for pid, t in targets.items()]
    return {"format": "femu.benchmark/1", "solvers": sorted({r.optimizer for r in runs}),
            "budget": max(r.budget for r in runs), "n_runs": len(runs), "problems": problems,
            "target_levels": list(st.target_levels()),
            "ert": st.ert_table(traces, targets), "ecdf": st.ecdfs(traces, targets),
            "fixed_budget": st.fixed_budget(traces, targets, budgets), "comparisons": comparisons,
            "not_compared": not_compared if not comparisons else None, "costs": costs(runs),
            "convergence": convergence(traces, targets)}


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
                rows.append([solver] + [f"{_g(per[group][i])} ({table.successes[solver][group][i]}/"
                                        f"{table.runs[solver][group]})" for i in ERT_COLUMNS])
        out += [f"**{group}**: ERT in FE evaluations (runs that hit / runs) per target, in decades below "
                "the problem's top target", ""]
        out += markdown_table(["solver"] + [f"top x 1e-{-round(math.log10(v))}" if v < 1 else "top" for v in levels], rows)
        out.append("")
    return out


def _fixed_budget_lines(s: dict) -> list[str]:
    rows = {}
    for fb in s["fixed_budget"]:
        q1, med, q3 = fb.quartiles
        rows.setdefault((fb.group, fb.solver), {})[fb.budget] = f"{_g(med)} [{_g(q1)}, {_g(q3)}]"
    budgets = sorted({fb.budget for fb in s["fixed_budget"]})
    return markdown_table(["group", "solver"] + [f"after {b}" for b in budgets],
                          [[g, so] + [v.get(b, "") for b in budgets] for (g, so), v in sorted(rows.items())])


def _comparison_lines(c: st.Comparison) -> list[str]:
    ranks = sorted(c.mean_ranks.items(), key=lambda kv: (kv[1], kv[0]))
    out = [f"Metric `{c.metric}` on {c.n_blocks} (problem, seed) blocks ({c.n_dropped_blocks} dropped): "
           + (f"Friedman chi2 = {c.friedman_statistic:.3g}, p = {c.friedman_p:.3g}; " if c.friedman_p is not None
              else "two solvers, no omnibus test; ")
           + f"Nemenyi CD = {c.critical_difference:.2f}.", ""]
    out += markdown_table(["solver", "mean rank"], [[k, f"{v:.2f}"] for k, v in ranks]) + [""]
    out += markdown_table(["a", "b", "Wilcoxon W", "p", "p (Holm)", "better (p Holm <= alpha)"],
                          [[p.a, p.b, f"{p.statistic:.3g}", f"{p.p:.3g}", f"{p.p_holm:.3g}", p.better or "-"]
                           for p in c.pairwise])
    return out + [""]


def render_benchmark(s: dict, figures: dict, source: str) -> str:
    """The Markdown of the benchmark report from `benchmark_statistics` and the figure names."""
    lines = [f"# Benchmark report: {', '.join(s['solvers'])}", "",
             f"{s['n_runs']} runs from {source}, budget {s['budget']} FE evaluations. Targets: J - f_opt at "
             f"{len(s['target_levels'])} levels, {st.PER_DECADE} per decade over {st.DECADES} decades from the "
             "power of ten at or above J(x0) - f_opt; fixed per problem, whatever solvers ran. Values below "
             "the last target are ties.", "", "## Problems", ""]
    lines += markdown_table(["id", "n_var", "f_opt", "known as", "J(x0)", "top target", "last target"],
                            [[p["id"], p["n_var"], f"{p['f_opt']:.10g}", p["f_opt_kind"], f"{p['f_start']:.4g}",
                              _g(p["targets"][0]), _g(p["targets"][-1])] for p in s["problems"]])
    lines += ["", "## Expected running time (ERT)", ""] + _ert_lines(s)
    lines += [f"![ERT]({figures['ert']})", "", "## Fixed-target ECDFs (instances pooled)", "",
              f"![ECDF]({figures['ecdf']})", "", "## Fixed-budget precision: median [q1, q3] of J - f_opt", ""]
    lines += _fixed_budget_lines(s) + [""] + [f"![fixed budget {g}]({f})" for g, f in figures["fixed_budget"].items()]
    lines += ["", "## Statistical comparison", "",
              "Scores per (problem, seed): `auc` = the fraction of (target, budget) pairs not reached (from the "
              "target-hitting times: earlier and more hits score lower), `final` = final J - f_opt raised to "
              "the last target. Friedman, then pairwise Wilcoxon signed-rank with Holm's correction (alpha "
              "0.05); ties below the last target are ties.", ""]
    for c in s["comparisons"].values():
        lines += _comparison_lines(c)
    if s["comparisons"]:
        lines += [f"![critical difference]({figures['cd']})", ""]
    else:
        lines += [f"No comparison: {s['not_compared']}", ""]
    lines += ["## Costs (medians per run)", ""]
    lines += markdown_table(["solver", "runs", "evaluations", "FE s", "optimizer s", "clock", "statuses"],
                            [[k, c["runs"], f"{c['median_evals']:.0f}", f"{c['median_fe_s']:.3g}",
                              f"{c['median_opt_s']:.3g}", c["clock"],
                              ", ".join(f"{n} {st_}" for st_, n in c["statuses"].items())]
                             for k, c in s["costs"].items()])
    lines += ["", "## Convergence per problem", ""] + [f"![convergence {g}]({f})" for g, f in figures["convergence"].items()]
    return "\n".join(lines) + "\n"


def write_benchmark(runs, out_dir, source: str) -> Path:
    """Write OUT/report.md, OUT/stats.json and the figures of the suite runs; returns report.md."""
    from . import stats_figures as sf

    s = benchmark_statistics(runs)
    out = make_out_dir(out_dir)
    groups = sorted({st.group_of(p["id"]) for p in s["problems"]})
    figures = {"ert": sf.plot_ert(s["ert"], out / "ert.png").name,
               "ecdf": sf.plot_ecdf(s["ecdf"], out / "ecdf.png").name,
               "fixed_budget": {g: sf.plot_fixed_budget(s["fixed_budget"], g, out / f"fixed_budget_{_stem(g)}.png").name
                                for g in groups},
               "convergence": {g: sf.plot_convergence([c for c in s["convergence"] if st.group_of(c["problem"]) == g],
                                                      out / f"convergence_{_stem(g)}.png").name for g in groups}}
    if s["comparisons"]:
        figures["cd"] = sf.plot_cd(s["comparisons"][COMPARISON_METRICS[0]] if COMPARISON_METRICS[0] in s["comparisons"]
                                   else next(iter(s["comparisons"].values())), out / "cd.png").name
    write_text(out / "stats.json", dumps(s) + "\n")
    path = out / "report.md"
    write_text(path, render_benchmark(s, figures, source))
    return path


def _stem(group: str) -> str:
    return group.replace("/", "_")
