"""Ending a run's process with everything it started: a plugin may spawn processes of its own
(a solver binary, a multiprocessing pool), and neither a timeout nor the end of its run may
leave them running.

`kill_tree`/`kill_descendants` end a tree politely (SIGTERM, `GRACE_S`, SIGKILL): for the
harness's own processes. A sandboxed run's worker is ended by `freeze` then `kill_frozen`:
its tree is stopped first, so that a plugin that ignores SIGTERM and keeps forking (in sessions
of their own) cannot start a process after the tree was listed."""

from __future__ import annotations

import os
import select
import signal
import time

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


#: Seconds `freeze_and_kill` waits for processes sent SIGKILL to have exited (one in an
#: uninterruptible wait, on a stalled disk say, may take that long; none has so far).
KILL_WAIT_S = 30.0


def _signal_root(pid: int, pidfd: int | None, sig: int) -> bool:
    """Send `sig` to process `pid`, through its pidfd when given (then never to a process that
    took the pid over once it was reaped); False when it is gone."""
    try:
        if pidfd is not None:
            signal.pidfd_send_signal(pidfd, sig)
        else:
            os.kill(pid, sig)
        return True
    except OSError:  # gone (ProcessLookupError), or not ours any more
        return False


def freeze(pid: int, pidfd: int | None = None, exclude=()) -> list:
    """Stop process `pid` (SIGSTOP, through `pidfd` when given), then its descendants, listing
    them again until a listing finds none not yet stopped: once it returns, nothing in the tree
    can start a process (a stopped process forks nothing), so a SIGKILL to each of them leaves
    none behind. Pids in `exclude` are left running (the caller's helper). Returns the stopped
    descendants as psutil.Process ([] when `pid` is gone)."""
    if not _signal_root(pid, pidfd, signal.SIGSTOP):
        return []
    try:
        root = psutil.Process(pid)
    except psutil.NoSuchProcess:
        return []
    stopped: dict[int, psutil.Process] = {}
    while True:
        try:
            new = [p for p in root.children(recursive=True) if p.pid not in stopped and p.pid not in exclude]
        except psutil.NoSuchProcess:
            break
        if not new:
            break
        for p in new:
            try:
                p.send_signal(signal.SIGSTOP)  # psutil refuses a pid reused since it was listed
            except psutil.NoSuchProcess:
                pass
            stopped[p.pid] = p
    return list(stopped.values())


def kill_frozen(pid: int, pidfd: int | None, procs: list) -> None:
    """SIGKILL to the frozen `procs` (`freeze`'s) and to `pid` (through `pidfd` when given),
    then return once all have exited (at most `KILL_WAIT_S`). With `pidfd` the root's exit is
    awaited on it (no polling of the process table)."""
    for p in procs:
        try:
            p.kill()
        except psutil.NoSuchProcess:
            pass
    if _signal_root(pid, pidfd, signal.SIGKILL) and pidfd is not None:
        t0 = time.perf_counter()
        while not select.select([pidfd], [], [], 0.5)[0] and time.perf_counter() - t0 < KILL_WAIT_S:
            _signal_root(pid, pidfd, signal.SIGKILL)
    elif pidfd is None:
        try:
            procs = procs + [psutil.Process(pid)]
        except psutil.NoSuchProcess:
            pass
    if procs:
        psutil.wait_procs(procs, timeout=KILL_WAIT_S)
