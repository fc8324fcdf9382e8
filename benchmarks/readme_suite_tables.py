"""The benchmark suite's tables (docs/benchmark-tables.md), from `femu report`'s numbers.

    femu report runs/suite12 --json > stats.json     # or the stats.json of `femu report --out`
    python benchmarks/readme_suite_tables.py stats.json --study "femu study ..." [--out docs/benchmark-tables.md]

Writes (default: prints) a Markdown page: the study's size; ERT (FE evaluations) with COCO's
bootstrapped 10-90 % range at 1, 3, 5, 7 and 10 decades below the top target per group; the
fixed-budget median [q1, q3] of J - f_opt after the full budget; the comparison on problems as
blocks (Friedman, mean ranks, Nemenyi's CD and cliques, Wilcoxon-Holm); the per-problem
Mann-Whitney tests; the aggregated ECDF's area; the profiles; the smallest p-values the design
can reach; the costs. Nothing is computed here that the report did not compute.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter

DECADES = (1, 3, 5, 7, 10)


def _g(v) -> str:
    return "inf" if v is None else f"{v:.3g}"


def _table(header: list[str], rows: list[list]) -> list[str]:
    return (["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
            + ["| " + " | ".join(str(c) for c in r) + " |" for r in rows])


def ert_table(stats: dict, group: str) -> list[str]:
    ert, levels = stats["ert"], stats["ert"]["levels"]
    cols = [min(range(len(levels)), key=lambda k: abs(levels[k] - 10.0 ** -d)) for d in DECADES]
    rows = []
    for solver in stats["solvers"]:
        if group not in ert["ert"].get(solver, {}):
            continue
        runs = ert["runs"][solver][group]
        cells = []
        for k in cols:
            e = ert["ert"][solver][group][k]
            rng = f" [{_g(ert['lower'][solver][group][k])}, {_g(ert['upper'][solver][group][k])}]" if e is not None else ""
            flag = " beyond budget" if ert["beyond_budget"][solver][group][k] else ""
            cells.append(f"{_g(e)}{rng}{flag} ({ert['successes'][solver][group][k]}/{runs})")
        rows.append([solver] + cells)
    return _table(["solver"] + [f"top x 1e-{d}" for d in DECADES], rows)


def fixed_budget_table(stats: dict) -> list[str]:
    rows = [r for r in stats["fixed_budget"] if r["budget"] == stats["budget"]]
    groups = sorted({r["group"] for r in rows})
    cell = {(r["solver"], r["group"]): "{1} [{0}, {2}]".format(*map(_g, r["quartiles"])) for r in rows}
    return _table(["solver"] + groups, [[s] + [cell.get((s, g), "-") for g in groups] for s in stats["solvers"]])


def comparison_lines(stats: dict) -> list[str]:
    if not stats["comparisons"]:
        return [f"No comparison on problems as blocks: {stats['not_compared']}"]
    out = []
    for value, c in stats["comparisons"].items():
        ranks = sorted(c["mean_ranks"].items(), key=lambda kv: kv[1])
        fried = (f"Friedman chi2 = {c['friedman_statistic']:.3g}, p = {c['friedman_p']:.2g}; "
                 if c["friedman_p"] is not None else "two solvers: no Friedman test; ")
        out += [f"**`{value}`** ({c['value_name']}) on {c['n_blocks']} problems as blocks: {fried}"
                f"Nemenyi CD = {c['critical_difference']:.2f}; cliques (mean ranks closer than the CD): "
                + ("; ".join(", ".join(cl) for cl in c["cliques"]) or "none") + ".", ""]
        out += _table(["solver", "mean rank"], [[s, f"{r:.2f}"] for s, r in ranks]) + [""]
        out += _table(["a", "b", "p (Wilcoxon)", "p (Holm)", "better"],
                      [[p["a"], p["b"], f"{p['p']:.2g}", f"{p['p_holm']:.2g}", p["better"] or "-"]
                       for p in c["pairwise"]]) + [""]
    return out


def per_problem_lines(stats: dict) -> list[str]:
    out = []
    for metric, t in stats["per_problem"].items():
        wins = Counter((p["a"], p["b"], p["better"]) for p in t["pairs"] if p["better"])
        pairs = sorted({(p["a"], p["b"]) for p in t["pairs"]})
        n_prob = {pr: sum(1 for p in t["pairs"] if (p["a"], p["b"]) == pr) for pr in pairs}
        out += [f"**`{metric}`**: {len(t['pairs'])} Mann-Whitney U tests, Holm over all (smallest reachable p "
                f"{t['smallest_p']:.2g}, {t['smallest_p_holm']:.2g} after Holm). Problems on which each pair is "
                "separated, by the better solver:", ""]
        out += _table(["a", "b", "problems", "a better", "b better"],
                      [[a, b, n_prob[(a, b)], wins.get((a, b, a), 0), wins.get((a, b, b), 0)] for a, b in pairs]) + [""]
    return out


def aggregate_lines(stats: dict) -> list[str]:
    a = stats["aggregate"]
    rows = sorted(a["area"].items(), key=lambda kv: -kv[1])
    return (["Area under the ECDF aggregated over every (problem, target) pair, on log10(evaluations / "
             f"dimension) from {a['lower']:.3g} to {a['upper']:.3g} (1: every target at once):", ""]
            + _table(["solver", "ECDF area"], [[s, f"{v:.3f}"] for s, v in rows]))


def profile_lines(stats: dict) -> list[str]:
    rows = []
    for p in stats["profiles"]:
        for s in stats["solvers"]:
            rows.append([f"{p['tolerance']:g}", s, f"{p['data'][s][-1]:.2f}", f"{p['performance'][s][0]:.2f}"])
    return (["Moré-Wild / Dolan-Moré profiles, the end points: the data profile at its largest alpha (the fraction "
             "of problems whose ERT to J <= f_opt + tau (J(x0) - f_opt) is at most the budget) and the performance "
             "profile at ratio 1 (the fraction of problems on which the solver's ERT is the best):", ""]
            + _table(["tau", "solver", "solved within the budget", "best"], rows))


def design_line(stats: dict) -> str:
    d = stats["design"]
    parts = [f"{d['solvers']} solvers, {d['problems']} problems, at least {d['fewest_runs']} runs per solver and problem"]
    if "mannwhitneyu" in d:
        parts.append(f"smallest Mann-Whitney p {d['mannwhitneyu']:.2g} ({d['mannwhitneyu_holm']:.2g} after Holm over "
                     f"{d['per_problem_tests']} tests)")
    if "wilcoxon_holm" in d:
        parts.append(f"smallest Wilcoxon-Holm p on the problems {d['wilcoxon_holm']:.2g}")
    if "friedman" in d:
        parts.append(f"smallest Friedman p {d['friedman']:.2g}")
    w = d.get("power")
    if w:  # the report's power statement (femu.reports.stats.wilcoxon_power)
        parts.append(f"power {w['power']:.0%} for a Wilcoxon-Holm pair at standardized per-problem difference dz "
                     + (f">= {w['detectable_dz']:.2f}" if w["detectable_dz"] is not None else "none (too few problems)")
                     + f", at least {w['min_problems']} problems to separate a pair at all; problems needed: "
                     + ", ".join(f"dz {k}: {v}" for k, v in w["problems_needed"].items()))
    return "Design: " + "; ".join(parts) + "."


def costs_table(stats: dict) -> list[str]:
    c = stats["costs"]
    return _table(["solver", "runs", "median FE s", "median optimizer s", "clock"],
                  [[s, c[s]["runs"], f"{c[s]['median_fe_s']:.2g}", f"{c[s]['median_opt_s']:.2g}", c[s]["clock"]]
                   for s in stats["solvers"]])


def page(stats: dict, study: str) -> str:
    """The Markdown of docs/benchmark-tables.md."""
    lines = ["# Benchmark suite tables", "",
             "This page is for a reader comparing optimizers on the benchmark suite: the tables of one study. "
             "Generated by `python benchmarks/readme_suite_tables.py stats.json --study ...` from `femu report STORE "
             "--json`; nothing here is computed outside the report. Definitions (targets, ERT, blocks, tests, "
             "aggregates, profiles): [suite.md](suite.md).", "",
             f"Study: `{study}` ({stats['n_runs']} runs, budget {stats['budget']} FE evaluations).", "",
             design_line(stats), ""]
    prov = stats.get("provenance")
    if prov:  # the report's provenance: where the numbers (and the costs' seconds) were made
        commit = prov["commit"][:12] + (" with local changes" if prov["commit_dirty"] else "") if prov["commit"] else "none"
        lines += [f"Made by femu-bench {prov['femu_bench']} (commit {commit}), suite version {prov['suite_version']}, "
                  f"on {prov['host']} ({prov['platform']}, {prov.get('cpus')} CPUs, load average "
                  f"{' / '.join(map(str, prov.get('load_average') or ['unknown']))} when reported), "
                  f"{prov['date_utc']}; the runs' hosts: "
                  + ", ".join(f"{h} ({n})" for h, n in prov["records"]["hosts"].items())
                  + ". Costs are that machine's CPU seconds under its load then.", ""]
    for group in sorted({g for per in stats["ert"]["ert"].values() for g in per}):
        lines += [f"## ERT on {group}", "",
                  "FE evaluations [10 %, 90 % of COCO's bootstrapped run lengths with restarts] (runs that hit / runs), "
                  "at decades below the top target (1e2 x the family's scale):", ""] + ert_table(stats, group) + [""]
    lines += ["## Fixed budget", "", f"Median [q1, q3] of J - f_opt after {stats['budget']} evaluations:", ""]
    lines += fixed_budget_table(stats) + ["", "## Comparison on problems as blocks", ""] + comparison_lines(stats)
    lines += ["## Per-problem tests", ""] + per_problem_lines(stats)
    lines += ["## Aggregated ECDF", ""] + aggregate_lines(stats) + ["", "## Profiles", ""] + profile_lines(stats)
    lines += ["", "## Costs", ""] + costs_table(stats)
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    """Print the page, or write it to --out."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("stats", help="the JSON of `femu report STORE --json` (or the report's stats.json)")
    ap.add_argument("--study", default="(not given)", help="the femu study command that made the store")
    ap.add_argument("--out", default=None, help="write the page here (docs/benchmark-tables.md)")
    a = ap.parse_args(argv)
    with open(a.stats) as fh:
        text = page(json.load(fh), a.study)
    if a.out:
        with open(a.out, "w") as fh:
            fh.write(text)
    else:
        print(text, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
