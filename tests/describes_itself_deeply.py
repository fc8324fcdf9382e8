"""A plugin module whose import-time code makes its worker answer the evaluating side with JSON
nested 200,000 deep (issue 39): once as its description before a study, once as its ``ready``
before its run. Python's JSON parser recurses, so a reader without a depth bound raises
RecursionError; the sandbox refuses the message unparsed, and the plugin alone fails, named.
Imported by no test: only by name, in a worker."""

from __future__ import annotations

import sys

import adapters.sandbox_worker

# the worker server runs as ``python -m adapters.sandbox_worker``: its code is __main__'s
_worker = sys.modules["__main__"] if hasattr(sys.modules["__main__"], "ObjectiveProxy") else adapters.sandbox_worker

_DEEP = b"[" * 200_000 + b"]" * 200_000


def _deep(conn, obj, tag: bytes = b"") -> None:
    conn.send_bytes(tag + _DEEP)


_worker.send_json = _deep


class DescribesItselfDeeply:
    def minimize(self, objective, bounds, budget, rng):
        objective(rng.uniform(*bounds, size=(budget, len(bounds[0]))))
