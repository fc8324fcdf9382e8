"""Where a result comes from: the versions of Python and of every library a run depends on.

Recorded in each run record (RunResult.versions) and in a study's study.json, so that a
result that changes with a library release (pymoo < 0.6.2 reseeds numpy's global generator;
scipy's dual annealing changed its sampling) can be traced to it.
"""

from __future__ import annotations

import platform
from functools import lru_cache
from importlib.metadata import PackageNotFoundError, version

#: Distributions a run's numbers depend on (their versions go into every run record).
RUN_LIBRARIES = ("femu-bench", "numpy", "scipy", "pymoo", "deap", "pyswarms", "cma", "ioh", "nevergrad",
                 "scikit-learn", "optuna", "cmaes")  # scikit-learn: nevergrad's MetaModel


@lru_cache(maxsize=None)
def library_versions(extra: tuple[str, ...] = ()) -> dict:
    """{"python": "3.x.y", distribution: version or None (not installed)} for RUN_LIBRARIES
    and `extra`, in that order. Cached: versions do not change inside a process."""
    out = {"python": platform.python_version()}
    for pkg in RUN_LIBRARIES + tuple(extra):
        try:
            out[pkg] = version(pkg)
        except PackageNotFoundError:
            out[pkg] = None
    return out
