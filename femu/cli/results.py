"""print the runs in a store"""

from __future__ import annotations

import sys

from ._args import add_store_argument, stored_runs


def add_arguments(r) -> None:
    """The arguments of `femu results`."""
    add_store_argument(r)
    r.add_argument("--json", action="store_true", help="print every run record as a JSON list instead of a table")


def run(args) -> int:
    """`femu results STORE [--json]`: the stored runs, as a table or a JSON list."""
    _, runs = stored_runs(args, "results")
    if args.json:
        from fe_problem.jsonutil import dumps

        sys.stdout.write(dumps([r.to_dict() for r in runs]) + "\n")
        return 0
    if not runs:
        print(f"no runs in {args.store}")
        return 0
    wv, wo = (max(len(h), *(len(getattr(r, h)) for r in runs)) for h in ("variant", "optimizer"))
    head = f"{'variant':<{wv}} {'optimizer':<{wo}} {'budget':>7} {'seed':>5} {'status':<8} {'n_evals':>8} " \
           f"{'best_f':>12} {'wall_s':>8}"
    print(head)
    print("-" * len(head))
    for r in runs:
        print(f"{r.variant:<{wv}} {r.optimizer:<{wo}} {r.budget:>7} {r.seed:>5} {r.status:<8} {r.n_evals:>8} "
              f"{r.best_f:>12.6g} {r.wall_s:>8.2f}")
    print(f"{len(runs)} runs in {args.store}")
    return 0
