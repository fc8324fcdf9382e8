"""Thread settings of the BLAS under numpy; imported before numpy by both packages."""

# Many small eigen-solves (39x39) run 10-100x slower with multi-threaded BLAS than with one
# thread, and processes of a study would compete for the cores: one BLAS thread per process
# unless the user says otherwise. Must run before numpy is first imported.
import os as _os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")
