"""the paper's comparison under one identical budget, with a report

Runs every available optimizer on the paper's data (variant 'paper') with the same seeds and
the same budget of FE evaluations into OUT/store (resumable: a second call runs only what is
missing), writes OUT/report.md with its figures and prints the medians over seeds as a table.
"""

from __future__ import annotations

from ._args import directory

import sys


def add_arguments(rr) -> None:
    """The arguments of `femu reproduce`."""
    from femu.reproduce import DEFAULT_BUDGET, DEFAULT_SEEDS, DEFAULT_TIME_LIMIT_S

    rr.add_argument("--seeds", default=str(DEFAULT_SEEDS),
                    help="a count N (the seeds 0..N-1) or a list of seeds as for `femu study` "
                         "(0-29, 0,3,7; one seed s is s-s); default: %(default)s, the seeds 0-4")
    rr.add_argument("--budget", type=int, default=DEFAULT_BUDGET, help="FE evaluations per run")
    rr.add_argument("--out", default="femu-reproduce", type=directory, help="output directory: OUT/store and OUT/report.md")
    rr.add_argument("--workers", type=int, default=None,
                    help="local worker processes (0: run in this process; default: every core)")
    rr.add_argument("--time-limit", type=float, default=DEFAULT_TIME_LIMIT_S,
                    help="wall-clock seconds per run before it is stopped (status timeout); default: %(default)s")
    rr.add_argument("--unconfined", action="store_true",
                    help="run even where this machine cannot confine the optimizers' workers (as femu study "
                         "--unconfined: the records say what did not hold)")
    out = rr.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true",
                     help="print the result as one JSON object (medians over seeds) instead of a table")
    out.add_argument("--markdown", action="store_true",
                     help="print the README's Markdown table of the result instead of the terminal table")


def run(args) -> int:
    """`femu reproduce`: run, report, print the table (or JSON, or Markdown)."""
    from fe_problem.jsonutil import dumps
    from femu.reports.reproduce import render_markdown, render_text
    from femu.reproduce import DEFAULT_TIME_LIMIT_S, reproduce

    res = reproduce(seeds=args.seeds, budget=args.budget, out=args.out, workers=args.workers,
                    time_limit_s=getattr(args, "time_limit", DEFAULT_TIME_LIMIT_S),
                    unconfined=getattr(args, "unconfined", False))
    if args.json:
        sys.stdout.write(dumps(res) + "\n")
    elif args.markdown:
        sys.stdout.write(render_markdown(res))
    else:
        print(render_text(res))
    return 0
