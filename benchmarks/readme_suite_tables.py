"""The README's benchmark-suite tables and comparison sentence, from `femu report`'s numbers.

    femu report runs/suite12 --json > stats.json     # or the stats.json of `femu report --out`
    python benchmarks/readme_suite_tables.py stats.json

Prints: ERT (FE evaluations; runs that hit / runs) on the first group at 1, 3, 5, 7 and 10
decades below the top target; the fixed-budget median [q1, q3] of J - f_opt after the full
budget per group; Friedman's test, the mean ranks and the pairs no Holm-corrected Wilcoxon test
separates, on the `auc` score. Nothing is computed here that the report did not compute.
"""

from __future__ import annotations

import json
import sys

DECADES = (1, 3, 5, 7, 10)


def _g(v) -> str:
    return "inf" if v is None else f"{v:.3g}"


def ert_table(stats: dict, group: str) -> str:
    ert, levels = stats["ert"], stats["ert"]["levels"]
    cols = [min(range(len(levels)), key=lambda k: abs(levels[k] - 10.0 ** -d)) for d in DECADES]
    lines = ["| solver | " + " | ".join(f"top x 1e-{d}" for d in DECADES) + " |", "|---" * (len(DECADES) + 1) + "|"]
    for solver in stats["solvers"]:
        runs = ert["runs"][solver][group]
        cells = [f"{_g(ert['ert'][solver][group][k])} ({ert['successes'][solver][group][k]}/{runs})" for k in cols]
        lines.append(f"| {solver} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def fixed_budget_table(stats: dict) -> str:
    rows = [r for r in stats["fixed_budget"] if r["budget"] == stats["budget"]]
    groups = sorted({r["group"] for r in rows})
    cell = {(r["solver"], r["group"]): "{1} [{0}, {2}]".format(*map(_g, r["quartiles"])) for r in rows}
    lines = ["| solver | " + " | ".join(groups) + " |", "|---" * (len(groups) + 1) + "|"]
    lines += [f"| {s} | " + " | ".join(cell.get((s, g), "-") for g in groups) + " |" for s in stats["solvers"]]
    return "\n".join(lines)


def comparison(stats: dict, metric: str = "auc") -> str:
    c = stats["comparisons"][metric]
    ranks = sorted(c["mean_ranks"].items(), key=lambda kv: kv[1])
    same = [p for p in c["pairwise"] if p["better"] is None]
    return (f"{metric}: {c['n_blocks']} blocks; Friedman chi2 = {c['friedman_statistic']:.3g}, "
            f"p = {c['friedman_p']:.2g}; mean ranks " + ", ".join(f"{s} {r:.2f}" for s, r in ranks)
            + f"; {len(same)} of {len(c['pairwise'])} pairs not separated (Holm): "
            + ", ".join(f"{p['a']}/{p['b']} ({p['p_holm']:.2g})" for p in same))


def costs(stats: dict) -> str:
    c = stats["costs"]
    return ("median CPU seconds per run, FE / optimizer: "
            + ", ".join(f"{s} {c[s]['median_fe_s']:.2g} / {c[s]['median_opt_s']:.2g}" for s in stats["solvers"]))


def main(path: str) -> None:
    with open(path) as fh:
        stats = json.load(fh)
    group = sorted(next(iter(stats["ert"]["ert"].values())))[0]
    print(f"ERT on {group}:\n\n{ert_table(stats, group)}\n")
    print(f"Fixed budget, median [q1, q3] of J - f_opt after {stats['budget']} evaluations:\n\n"
          f"{fixed_budget_table(stats)}\n")
    print(comparison(stats))
    print(costs(stats))


if __name__ == "__main__":
    main(sys.argv[1])
