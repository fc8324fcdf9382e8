"""the paper's comparison under one identical budget, with a report"""

from __future__ import annotations

import json
import sys


def add_arguments(rr) -> None:
    rr.add_argument("--seeds", type=int, default=None, help="number of seeds")
    rr.add_argument("--budget", type=int, default=None, help="FE evaluations per run")
    rr.add_argument("--out", default="femu-reproduce", help="output directory (store and report)")
    rr.add_argument("--workers", type=int, default=None)
    rr.add_argument("--json", action="store_true")


def run(args) -> int:
    """`femu reproduce [--seeds N] [--budget B] [--out DIR] [--workers K] [--json]`."""
    from femu.reproduce import DEFAULT_BUDGET, DEFAULT_SEEDS, render_text, reproduce

    res = reproduce(seeds=DEFAULT_SEEDS if args.seeds is None else args.seeds,
                    budget=DEFAULT_BUDGET if args.budget is None else args.budget,
                    out=args.out, workers=args.workers)
    if args.json:
        json.dump(res, sys.stdout, indent=1)
        sys.stdout.write("\n")
    else:
        print(render_text(res))
    return 0
