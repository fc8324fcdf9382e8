"""Markdown report with figures from a store

Give --out DIR (the report: report.md and its figures), --json (the benchmark statistics on
stdout), or both: one of them is required. Example:

  femu report runs/ --out report/ --ioh --coco
"""

from __future__ import annotations

from ._args import add_store_argument, directory, stored_runs


def add_arguments(rp) -> None:
    """The arguments of `femu report`."""
    add_store_argument(rp)
    rp.add_argument("--out", type=directory, default=None,
                    help="output directory: report.md, summary.json (stats.json for suite runs) and PNG figures "
                         "(required unless --json)")
    rp.add_argument("--json", action="store_true",
                    help="print the benchmark statistics of the runs as JSON (targets, ERT with its bootstrapped "
                         "range, comparisons on problems as blocks, per-problem tests, aggregate ECDF, profiles); "
                         "with --out, also write the report (required unless --out)")
    rp.add_argument("--ioh", action="store_true", help="also export IOHprofiler files to OUT/ioh")
    rp.add_argument("--coco", action="store_true", help="also export COCO data (for cocopp) to OUT/coco")


def run(args) -> int:
    """`femu report STORE --out DIR [--ioh] [--coco]`, `femu report STORE --json [--out DIR]`."""
    from femu.reports.study import write_report

    if args.out is None and not args.json:
        raise ValueError("the following arguments are required: --out DIR (the report), or --json (the "
                         "benchmark statistics on stdout)")
    for flag in ("ioh", "coco"):
        if args.out is None and getattr(args, flag):
            raise ValueError(f"--{flag} writes to OUT/{flag} and needs --out DIR")
    if args.ioh:
        from adapters.extras import require

        require("--ioh (IOHprofiler export)", "ioh")  # before the report: the extra to install
    store, runs = stored_runs(args, "report")
    if args.json:
        from fe_problem.jsonutil import dumps
        from femu.reports.benchmark import benchmark_statistics

        stats = benchmark_statistics(runs)
        if args.out is not None:
            write_report(runs, args.out, ioh=args.ioh, coco=args.coco, source=f"store `{store.path}`", unsigned=store.unsigned())
        print(dumps(stats))
        return 0
    path = write_report(runs, args.out, ioh=args.ioh, coco=args.coco, source=f"store `{store.path}`", unsigned=store.unsigned())
    print(f"report written to {path}")
    if args.ioh:
        print(f"IOHprofiler files in {path.parent / 'ioh'}")
    if args.coco:
        print(f"COCO data in {path.parent / 'coco'} (cocopp: see docs/suite.md)")
    return 0
