"""Each built-in against its library's own driver at equal evaluations, on two suite problems:
median J - f_opt over seeds of the adapter and of the reference (benchmarks/references.py),
and their ratio (adapter / reference; below 1: the adapter is better).

    cd benchmarks && OPENBLAS_NUM_THREADS=1 python adapter_references.py --budget 1000 --seeds 5 --write

--write puts the rows into the table in docs/suite-adapters.md (between its "adapter-references"
markers), keeping the rows of built-ins not run this time (`--optimizers optuna-tpe` updates
that built-in's rows alone; a table of another budget or other seeds is refused); without it
the table is printed. Runs go through `adapters.run`, so the numbers are the ones a
study would store. --optimizers selects built-ins (default: every one with a reference).
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from adapters import run  # noqa: E402
from fe_problem import suite_problem  # noqa: E402
from references import REFERENCES  # noqa: E402

PROBLEMS = ("hframe-freq/12/1", "hframe-shape/12/1")
#: J - f_opt below this counts as this (the ratio of two exact hits is 1, not 0/0)
FLOOR = 1e-14
BEGIN, END = "<!-- adapter-references: begin -->", "<!-- adapter-references: end -->"


def median_delta(name: str, problem_id: str, budget: int, seeds) -> float:
    """Median over seeds of J - f_opt (floored at FLOOR) of `name`'s runs."""
    out = []
    for s in seeds:
        p = suite_problem(problem_id)
        r = run(name, p, budget, s)
        if r.status != "ok":
            raise RuntimeError(f"{name} on {problem_id} seed {s}: {r.status}: {r.error}")
        out.append(max(r.best_f - p.f_opt, FLOOR))
    return statistics.median(out)


def ratios(names, budget: int, seeds, problems=PROBLEMS) -> list[dict]:
    """One row per (built-in, problem): medians of the adapter and its reference, their ratio."""
    rows = []
    for name in names:
        ref, what = REFERENCES[name]
        for pid in problems:
            a, b = median_delta(name, pid, budget, seeds), median_delta(ref, pid, budget, seeds)
            rows.append({"optimizer": name, "reference": what, "problem": pid, "adapter": a, "library": b,
                         "ratio": a / b})
            print(f"{name} on {pid}: {a:.3g} / {b:.3g} = {a / b:.3g}", file=sys.stderr, flush=True)
    return rows


def table(rows, budget: int, seeds) -> str:
    """The Markdown table of `ratios`."""
    lines = [f"Median J - f_opt over seeds {seeds[0]}-{seeds[-1]} at {budget} FE evaluations (floored at {FLOOR:g}); "
             "ratio = adapter / reference (below 1: the adapter is better). Regenerate: "
             f"`cd benchmarks && OPENBLAS_NUM_THREADS=1 python adapter_references.py --budget {budget} "
             f"--seeds {len(seeds)} --write`.", "",
             "| built-in | reference | problem | adapter | reference | ratio |", "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| `{r['optimizer']}` | {r['reference']} | {r['problem']} | {r['adapter']:.3g} | "
                     f"{r['library']:.3g} | {r['ratio']:.3g} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--optimizers", default=",".join(REFERENCES),
                    help="built-ins, comma-separated (mlp-surrogate and nevergrad-ngopt take minutes per run)")
    ap.add_argument("--budget", type=int, default=1000)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--write", action="store_true", help="write the table into docs/suite-adapters.md")
    args = ap.parse_args(argv)
    seeds = list(range(args.seeds))
    text = table(ratios(args.optimizers.split(","), args.budget, seeds), args.budget, seeds)
    if not args.write:
        print(text)
        return 0
    doc = HERE.parent / "docs" / "suite-adapters.md"
    s = doc.read_text()
    if BEGIN not in s:
        s = s.rstrip("\n") + "\n\n## Adapters against their libraries\n\n" + BEGIN + "\n" + END + "\n"
    head, rest = s.split(BEGIN)
    old, tail = rest.split(END, 1)
    doc.write_text(head + BEGIN + "\n" + merged(old, text, args.optimizers.split(",")) + "\n" + END + tail)
    print(f"wrote the table into {doc}")
    return 0


def merged(old: str, new: str, names) -> str:
    """The table `new` with the rows of `old` for the built-ins not in `names` kept, in the order
    of REFERENCES: one built-in's rows are regenerated without running the others again. Refused
    (ValueError) when `old` was made at another budget or with other seeds (its first line)."""
    old_lines, new_lines = old.strip().splitlines(), new.strip().splitlines()
    if not old_lines:
        return new
    if old_lines[0] != new_lines[0]:
        raise ValueError("the table in docs/suite-adapters.md was made with another budget or other seeds "
                         f"({old_lines[0][:80]}...): regenerate every row (--optimizers {','.join(REFERENCES)})")
    rows = {}
    for line in old_lines[4:] + new_lines[4:]:  # the new rows after the old: they replace them
        name = line.split("`")[1]
        rows.setdefault(name, {})[line.split("|")[3].strip()] = line
    kept = [n for n in REFERENCES if n in rows] + [n for n in rows if n not in REFERENCES]
    return "\n".join(new_lines[:4] + [line for n in kept for line in rows[n].values()])


if __name__ == "__main__":
    sys.exit(main())
