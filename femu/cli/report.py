"""Markdown report with figures from a store"""

from __future__ import annotations


def add_arguments(rp) -> None:
    rp.add_argument("store")
    rp.add_argument("--out", required=True, help="output directory")
    rp.add_argument("--ioh", action="store_true", help="also export IOHprofiler files")


def run(args) -> int:
    """`femu report STORE --out DIR [--ioh]`."""
    from femu.reports.study import write_report
    from femu.studies.store import Store

    path = write_report(Store(args.store), args.out, ioh=args.ioh)
    print(f"report written to {path}")
    if args.ioh:
        print(f"IOHprofiler files in {path.parent / 'ioh'}")
    return 0
