"""Markdown report with figures from a store"""

from __future__ import annotations

from ._args import directory, warn_skipped


def add_arguments(rp) -> None:
    """The arguments of `femu report`."""
    rp.add_argument("store", help="the store directory a `femu study` wrote")
    rp.add_argument("--out", required=True, type=directory, help="output directory: report.md, summary.json and PNG figures")
    rp.add_argument("--ioh", action="store_true", help="also export IOHprofiler files to OUT/ioh")
    rp.add_argument("--skip-invalid", action="store_true",
                    help="leave out damaged or hand-edited run records (each named on stderr) instead of stopping")


def run(args) -> int:
    """`femu report STORE --out DIR [--ioh]`."""
    from femu.reports.study import write_report
    from femu.studies.store import Store

    store = Store(args.store)
    runs = store.runs(skip_invalid=args.skip_invalid)
    warn_skipped(store, "femu report")
    path = write_report(runs, args.out, ioh=args.ioh, source=f"store `{store.path}`")
    print(f"report written to {path}")
    if args.ioh:
        print(f"IOHprofiler files in {path.parent / 'ioh'}")
    return 0
