"""Ending a run's process with everything it started: a plugin may spawn processes of its own
(a solver binary, a multiprocessing pool), and neither a timeout nor the end of its run may
leave them running."""

from __future__ import annotations

import os

import psutil

#: Seconds a process gets to exit after SIGTERM before it is sent SIGKILL.
GRACE_S = 2.0


def kill_tree(pid: int) -> None:
    """Terminate process `pid` and all its descendants (children first collected, so that
    none is orphaned on the way), then kill whatever is still alive after `GRACE_S`."""
    try:
        root = psutil.Process(pid)
        procs = root.children(recursive=True) + [root]
    except psutil.NoSuchProcess:
        return
    _end(procs)


def kill_descendants() -> int:
    """End every process this process started (and theirs), leaving this one running; for a
    run's worker process once its run is over. Returns how many there were."""
    try:
        procs = psutil.Process(os.getpid()).children(recursive=True)
    except psutil.NoSuchProcess:
        return 0
    _end(procs)
    return len(procs)


def _end(procs: list) -> None:
    """SIGTERM to each of `procs`, SIGKILL to those alive after `GRACE_S`; all reaped."""
    for p in procs:
        try:
            p.terminate()
        except psutil.NoSuchProcess:
            pass
    _, alive = psutil.wait_procs(procs, timeout=GRACE_S)
    for p in alive:
        try:
            p.kill()
        except psutil.NoSuchProcess:
            pass
    psutil.wait_procs(alive, timeout=GRACE_S)
