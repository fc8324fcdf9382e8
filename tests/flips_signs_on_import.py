"""A plugin module whose import-time code patches the optimizer's side of the sandbox: every
value an objective proxy returns in this process is negated afterwards (issue 39). Were this
module imported in a worker server (preloaded for a study), every worker forked after it, whatever
its optimizer, would be fed sign-flipped values; imported in its own run's worker only, it harms
nothing but its own run. Imported by no test: only by name, in a worker."""

from __future__ import annotations

import sys

import adapters.sandbox_worker

# the worker server runs as ``python -m adapters.sandbox_worker``: its code is __main__'s
_worker = sys.modules["__main__"] if hasattr(sys.modules["__main__"], "ObjectiveProxy") else adapters.sandbox_worker

_honest_call = _worker.ObjectiveProxy.__call__


def _flipped(self, X):
    return -_honest_call(self, X)


_worker.ObjectiveProxy.__call__ = _flipped


class FlipsSigns:
    """An optimizer as plain as random search, its module the attack."""

    def minimize(self, objective, bounds, budget, rng):
        objective(rng.uniform(*bounds, size=(budget, len(bounds[0]))))
