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


def git_commit(path=None) -> tuple[str | None, bool | None]:
    """(commit, dirty) of the git work tree holding `path` (default: this package's source), or
    (None, None) when it is not in one (an installed wheel) or git is not there. dirty: tracked
    files differ from the commit."""
    import subprocess
    from pathlib import Path

    root = Path(path) if path is not None else Path(__file__).resolve().parents[1]

    def git(*args) -> str | None:
        try:
            done = subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True, timeout=10)
        except (OSError, subprocess.SubprocessError):
            return None
        return done.stdout.strip() if done.returncode == 0 else None

    commit = git("rev-parse", "HEAD")
    if commit is None:
        return None, None
    status = git("status", "--porcelain", "--untracked-files=no")
    return commit, None if status is None else bool(status)


def provenance(extra: tuple[str, ...] = ()) -> dict:
    """Where a report comes from: femu-bench's version and git commit (None where not in a
    work tree), the benchmark suite's version, host, platform, its CPUs and load average (1, 5,
    15 min; None where the system has none), the date (UTC, ISO 8601) and the versions of
    Python and the run libraries (`library_versions`)."""
    from datetime import datetime, timezone

    from fe_problem.suite import SUITE_VERSION

    import os

    versions = library_versions(tuple(extra))
    commit, dirty = git_commit()
    try:  # how busy the host was: timings in the report are this machine's under this load
        load = [round(v, 2) for v in os.getloadavg()]
    except (AttributeError, OSError):
        load = None
    return {"femu_bench": versions.get("femu-bench"), "commit": commit, "commit_dirty": dirty,
            "suite_version": SUITE_VERSION, "host": platform.node(), "platform": platform.platform(),
            "cpus": os.cpu_count(), "load_average": load,
            "date_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"), "versions": versions}


def runs_provenance(runs) -> dict:
    """What the run records say of their own provenance: the hosts they ran on, the suite
    versions and femu-bench versions they were made with ("unrecorded" for records older than
    the field), each with its number of runs."""
    from collections import Counter

    def count(values) -> dict:
        return dict(sorted(Counter("unrecorded" if v in (None, "") else str(v) for v in values).items()))

    runs = list(runs)
    return {"runs": len(runs), "hosts": count(getattr(r, "host", None) for r in runs),
            "suite_versions": count(getattr(r, "suite_version", None) for r in runs),
            "femu_bench": count((getattr(r, "versions", None) or {}).get("femu-bench") for r in runs)}
