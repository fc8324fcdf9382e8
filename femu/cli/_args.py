"""Argument types and output helpers shared by the commands."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def positive_int(text: str) -> int:
    """An argparse type: a whole number >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


#: Why an empty output path is refused: it would mean the current directory without saying so.
EMPTY_PATH = "an empty path; name a directory (use . for the current one)"


def directory(text: str) -> str:
    """An argparse type: a directory to write into (made if missing). Refuses an empty path
    (`EMPTY_PATH`) and an existing non-directory."""
    if not text.strip():
        raise argparse.ArgumentTypeError(EMPTY_PATH)
    if Path(text).exists() and not Path(text).is_dir():
        raise argparse.ArgumentTypeError(f"{text} exists and is not a directory")
    return text


def print_json(obj) -> None:
    """``obj`` as indented JSON on stdout (numpy values and dataclasses made plain)."""
    from fe_problem.jsonutil import dumps  # numpy: not for `femu --help`

    sys.stdout.write(dumps(obj) + "\n")


def add_store_argument(parser) -> None:
    """The STORE argument of the commands that read a study's store, and --skip-invalid."""
    parser.add_argument("store", help="the store directory a `femu study` wrote")
    parser.add_argument("--skip-invalid", action="store_true",
                        help="leave out damaged or hand-edited run records (each named on stderr) instead of stopping")


def stored_runs(args, command: str):
    """(store, its runs) for the STORE argument; each damaged record left out (with
    --skip-invalid) is named in one warning line on stderr."""
    from femu.studies.store import Store

    store = Store(args.store)
    runs = store.runs(skip_invalid=args.skip_invalid)
    for message in store.skipped:
        print(f"femu {command}: warning: left out {message}", file=sys.stderr)
    return store, runs
