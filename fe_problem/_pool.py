"""The worker processes that share a batch of independent points with this process.

The pool is loky's (through joblib): its workers are fresh interpreters that import only what
a task needs (this module, the solver's class) and never the user's main module, so a script
without `if __name__ == "__main__":`, a script fed on standard input and code run cell by cell
in a notebook work unchanged: nothing of theirs runs again in a worker. (The standard library's
"spawn" and "forkserver" start methods re-import `__main__` in every worker.)

One pool serves the whole program (not one per model: a diagnosis builds hundreds of models);
it starts at the first parallel batch. A task carries its solver pickled once and a token; a
worker keeps the last few solvers it was sent. A worker sets `FEMU_SOLVER_WORKERS=1`: its own
batches stay in it.
"""

from __future__ import annotations

import pickle
from concurrent.futures.process import BrokenProcessPool  # loky's own is a subclass
from typing import Any, Callable

from ._threads import one_blas_thread

#: The environment of a worker process: one BLAS thread (thousands of small solves), and no
#: pool of its own.
WORKER_ENV = {"FEMU_SOLVER_WORKERS": "1", "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
              "MKL_NUM_THREADS": "1"}

_POOL = None  # a loky ProcessPoolExecutor
_POOL_SIZE = 0
_KEPT: dict[str, Any] = {}
_KEEP = 4


def _executor(size: int):
    """The shared pool, with at least `size` processes."""
    global _POOL, _POOL_SIZE
    # imported here: a program that never runs a parallel batch does not need joblib
    from joblib.externals.loky import ProcessPoolExecutor
    from joblib.externals.loky.backend import get_context

    if _POOL is None or _POOL_SIZE < size:
        if _POOL is not None:
            _POOL.shutdown(wait=True)
        # the "loky" context (not "loky_init_main"): workers do not run the parent's __main__
        _POOL = ProcessPoolExecutor(size, context=get_context("loky"), env=dict(WORKER_ENV))
        _POOL_SIZE = size
    return _POOL


def drop() -> None:
    """Forget the shared pool (its workers are ended); the next parallel batch starts a new one."""
    global _POOL, _POOL_SIZE
    if _POOL is not None:
        _POOL.shutdown(wait=False, kill_workers=True)
    _POOL, _POOL_SIZE = None, 0


def worker_pids() -> list[int]:
    """Process ids of the shared pool's workers (empty when no pool runs)."""
    return [] if _POOL is None else list(_POOL._processes)


def _run(token: str, blob: bytes, method: str, items, args: tuple) -> list:
    """A worker's share: `getattr(obj, method)(item, *args)` for every item, in order, with
    `obj` the object pickled in `blob` (unpickled once per token and kept)."""
    obj = _KEPT.get(token)
    if obj is None:
        obj = pickle.loads(blob)
        if len(_KEPT) >= _KEEP:
            _KEPT.pop(next(iter(_KEPT)))
        _KEPT[token] = obj
    call = getattr(obj, method)
    with one_blas_thread():  # as in the parent (AffineModel.eigen): results independent of the thread count
        return [call(item, *args) for item in items]


def map_split(local: Callable, token: str, blob: Callable[[], bytes], method: str, parts: list,
              args: tuple) -> list:
    """The results of `local(item, *args)` for every item of every part, in order: parts[0] in
    this process, the others in the pool's workers (by `method` of the object pickled in
    `blob()`). A share whose worker died, or that no worker could take, is done here: the
    results are the same either way."""
    futures = None
    if len(parts) > 1:
        data = blob()
        for _ in range(2):  # a pool found broken is replaced once
            try:
                pool = _executor(len(parts) - 1)
                futures = [pool.submit(_run, token, data, method, part, args) for part in parts[1:]]
                break
            except BrokenProcessPool:
                drop()
    res = [local(item, *args) for item in parts[0]]  # this process takes a share
    for i, part in enumerate(parts[1:]):
        if futures is not None:
            try:
                res += futures[i].result()
                continue
            except BrokenProcessPool:  # a worker died (killed, out of memory)
                drop()
                futures = None
        res += [local(item, *args) for item in part]
    return res


__all__ = ["WORKER_ENV", "drop", "map_split", "worker_pids"]
