"""Argument types and output helpers shared by the commands."""

from __future__ import annotations

import argparse
import sys

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


def print_json(obj) -> None:
    """``obj`` as indented JSON on stdout (numpy values and dataclasses made plain)."""
    sys.stdout.write(dumps(obj) + "\n")
