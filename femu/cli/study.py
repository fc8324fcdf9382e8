"""run a grid of optimizers x seeds into a store (resumable)"""

from __future__ import annotations

import sys



def add_arguments(s) -> None:
    from adapters.registry import available

    s.add_argument("--optimizers", required=True, help="comma-separated names: " + ", ".join(available()))
    s.add_argument("--seeds", required=True, help="e.g. 0-29 or 0,1,5")
    s.add_argument("--budget", type=int, required=True, help="FE evaluations per run")
    s.add_argument("--store", required=True, help="directory of the result store")
    s.add_argument("--workers", type=int, default=None, help="local processes (default: all cores)")
    s.add_argument("--scheduler", default=None, help="address of a Dask scheduler (tcp://host:port)")
    s.add_argument("--variants", default="paper", help="problem variants, comma-separated (paper, synthetic)")
    s.add_argument("--time-limit", type=float, default=None, help="seconds per run before it is stopped")
    s.add_argument("--no-progress", action="store_true", help="no progress bar")
    s.add_argument("--retry-failed", action="store_true",
                   help="run again the runs stored as failed or timeout (they are kept otherwise)")


def run(args) -> int:
    """`femu study`: run the grid into the store, print a one-line summary."""
    from femu.studies.study import run_study

    try:
        result = run_study(args.optimizers, args.seeds, args.budget, args.store, variants=args.variants,
                           workers=args.workers, scheduler=args.scheduler, time_limit_s=args.time_limit,
                           progress=not args.no_progress, retry_failed=getattr(args, "retry_failed", False))
    except KeyboardInterrupt:
        print(f"femu study: interrupted; the finished runs are in {args.store}: the same command resumes the study",
              file=sys.stderr)
        return 130
    print(result.summary())
    return 0
