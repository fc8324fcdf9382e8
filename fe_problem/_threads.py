"""Thread settings of the BLAS under numpy; imported before numpy by both packages."""

# Many small eigen-solves (39x39) run 10-100x slower with multi-threaded BLAS than with one
# thread, and processes of a study would compete for the cores: one BLAS thread per process
# unless the user says otherwise. Must run before numpy is first imported.
import contextlib
import os as _os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")


def one_blas_thread():
    """A context in which the BLAS/OpenMP pools run one thread: every evaluation runs in it, so
    that J does not depend on the thread count a user set (a multi-threaded BLAS sums in another
    order: up to 2e-8 relative on some suite problems). threadpoolctl's controller is built once,
    at the first call, and so is the check whether any pool runs more than one thread: setting
    and restoring the count costs 0.5 ms a call, so a process whose pools run one thread (the
    default, `OPENBLAS_NUM_THREADS` unset) skips it. A pool widened later in the process (by
    threadpoolctl's own threadpool_limits, say) is not seen."""
    global _CONTROLLER, _WIDE
    if _CONTROLLER is None:
        from threadpoolctl import ThreadpoolController

        _CONTROLLER = ThreadpoolController()
        _WIDE = any(lib.num_threads != 1 for lib in _CONTROLLER.lib_controllers)
    return _CONTROLLER.limit(limits=1) if _WIDE else contextlib.nullcontext()


_CONTROLLER = None
_WIDE = True


def blas_pinned(func):
    """`func` run inside `one_blas_thread` (a decorator): for building the matrices a problem
    evaluates with, which go through BLAS products too."""
    import functools

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with one_blas_thread():
            return func(*args, **kwargs)

    return wrapper
