"""Markdown report with figures from a store"""

from __future__ import annotations

from ._args import add_store_argument, directory, stored_runs


def add_arguments(rp) -> None:
    """The arguments of `femu report`."""
    add_store_argument(rp)
    rp.add_argument("--out", required=True, type=directory, help="output directory: report.md, summary.json and PNG figures")
    rp.add_argument("--ioh", action="store_true", help="also export IOHprofiler files to OUT/ioh")


def run(args) -> int:
    """`femu report STORE --out DIR [--ioh]`."""
    from femu.reports.study import write_report

    store, runs = stored_runs(args, "report")
    path = write_report(runs, args.out, ioh=args.ioh, source=f"store `{store.path}`")
    print(f"report written to {path}")
    if args.ioh:
        print(f"IOHprofiler files in {path.parent / 'ioh'}")
    return 0
