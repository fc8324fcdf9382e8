"""Run solvers on suite problems and draw the benchmark statistics: a preview of the study
report's statistics section, and the reference for wiring `femu study --suite` to it.

    python benchmarks/suite_stats_demo.py --suite hframe-freq/12,hframe-shape/12 \\
        --solvers cma-es,sensitivity,pymoo-ga,random-search --seeds 3 --budget 1000 --out /tmp/stats

Writes ecdf.png, ert.png, fixed_budget_<group>.png, cd.png and stats.json (targets, ERT, mean
ranks, Friedman, pairwise Wilcoxon-Holm) to --out.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from adapters import run
from fe_problem import select_suite, suite_problem
from fe_problem.jsonutil import dumps
from femu.reports import stats as st
from femu.reports import stats_figures as sf


def targets_of(problem_id: str) -> st.Targets:
    """The fixed targets of a suite problem: from its f_opt and J of its initial model x0."""
    p = suite_problem(problem_id)
    return st.fixed_targets(problem_id, p.f_opt, float(p.evaluate(p.x0)[0]))


def main(argv=None) -> int:
    """Run every solver x problem x seed, then compute and draw the statistics."""
    a = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    a.add_argument("--suite", default="hframe-freq/12,hframe-shape/12")
    a.add_argument("--solvers", default="cma-es,sensitivity,pymoo-ga,random-search")
    a.add_argument("--seeds", type=int, default=3)
    a.add_argument("--budget", type=int, default=1000)
    a.add_argument("--out", type=Path, default=Path("suite-stats"))
    args = a.parse_args(argv)
    ids = select_suite(args.suite)
    targets = {i: targets_of(i) for i in ids}
    records = []
    for i in ids:
        for solver in args.solvers.split(","):
            for seed in range(args.seeds):
                records.append(run(solver, suite_problem(i), args.budget, seed))
                print(f"{i} {solver} seed {seed}: J - f_opt = {records[-1].best_f - targets[i].f_opt:.3g}",
                      file=sys.stderr)
    runs = [st.RunTrace.of(r) for r in records]
    args.out.mkdir(parents=True, exist_ok=True)
    budgets = sorted({max(args.budget // 100, 1), args.budget // 10, args.budget})
    fixed = st.fixed_budget(runs, targets, budgets)
    result = {"targets": targets, "ert": st.ert_table(runs, targets),
              "comparison_final": st.compare(runs, targets, "final"),
              "comparison_auc": st.compare(runs, targets, "auc"), "fixed_budget": fixed}
    (args.out / "stats.json").write_text(dumps(result) + "\n")
    sf.plot_ecdf(st.ecdfs(runs, targets), args.out / "ecdf.png")
    sf.plot_ert(result["ert"], args.out / "ert.png")
    for g in sorted({st.group_of(i) for i in ids}):
        sf.plot_fixed_budget(fixed, g, args.out / f"fixed_budget_{g.replace('/', '_')}.png")
    sf.plot_cd(result["comparison_auc"], args.out / "cd.png")
    c = result["comparison_auc"]
    print(f"mean ranks (auc): {c.mean_ranks}\nFriedman p = {c.friedman_p}\n"
          + "\n".join(f"  {p.a} vs {p.b}: p_holm = {p.p_holm:.3g} better = {p.better}" for p in c.pairwise))
    return 0


if __name__ == "__main__":
    sys.exit(main())
