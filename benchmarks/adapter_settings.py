"""Adapters at their settings: median best J over seeds at one budget, one line per optimizer.

    OPENBLAS_NUM_THREADS=1 python benchmarks/adapter_settings.py --budget 2000 --seeds 5 \
        --optimizers scipy-sa,pymoo-ga,cma-es,pyswarms-pso

Prints a Markdown table: median / best / worst best_f over the seeds (0 .. seeds-1), the median
evaluation count of the last improvement (a method that stalls early shows a small number) and
the median optimizer CPU seconds. Runs go through `adapters.run` on the paper problem (or
``--variant synthetic``), so the numbers are the ones a study would store.
"""

from __future__ import annotations

import argparse
import statistics

from adapters import run
from adapters.variants import make_problem


def _row(name: str, variant: str, budget: int, seeds: int, options: dict) -> list[str]:
    records = [run(name, make_problem(variant), budget, s, **options) for s in range(seeds)]
    best = sorted(r.best_f for r in records)
    last = statistics.median(r.trace[-2][0] if len(r.trace) > 1 else r.trace[-1][0] for r in records)
    opt_cpu = statistics.median(getattr(r, "opt_cpu_s", r.cpu_s - r.fe_s) for r in records)
    failed = sum(r.status == "failed" for r in records)
    return [name, f"{statistics.median(best):.4g}", f"{best[0]:.4g}", f"{best[-1]:.4g}", f"{last:.0f}",
            f"{opt_cpu:.2f}", str(failed)]


def main(argv=None) -> int:
    """Run every optimizer on seeds 0 .. seeds-1 and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--optimizers", default="scipy-sa,pymoo-ga,cma-es,pyswarms-pso")
    ap.add_argument("--budget", type=int, default=2000)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--variant", default="paper")
    args = ap.parse_args(argv)
    head = ["optimizer", "median best_f", "best", "worst", "last improvement (eval)", "opt CPU s", "failed"]
    print(f"{args.variant}, budget {args.budget}, seeds 0-{args.seeds - 1}\n")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for name in args.optimizers.split(","):
        print("| " + " | ".join(_row(name, args.variant, args.budget, args.seeds, {})) + " |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
