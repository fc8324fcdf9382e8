"""Argument types and output helpers shared by the commands."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from fe_problem.jsonutil import dumps


def positive_int(text: str) -> int:
    """An argparse type: a whole number >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def directory(text: str) -> str:
    """An argparse type: a directory to write into (made if missing). Refuses an empty path
    (which would mean the current directory without saying so) and an existing non-directory."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path; name a directory (use . for the current one)")
    if Path(text).exists() and not Path(text).is_dir():
        raise argparse.ArgumentTypeError(f"{text} exists and is not a directory")
    return text


def print_json(obj) -> None:
    """``obj`` as indented JSON on stdout (numpy values and dataclasses made plain)."""
    sys.stdout.write(dumps(obj) + "\n")


def warn_skipped(store, command: str) -> None:
    """One line on stderr per damaged run record `store.runs(skip_invalid=True)` left out."""
    for message in store.skipped:
        print(f"{command}: warning: left out {message}", file=sys.stderr)
