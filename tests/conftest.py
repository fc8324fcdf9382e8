"""Test session settings."""

import os

# One BLAS thread (as the packages set on import): many small eigen-solves run far slower
# threaded on 2 cores; set here too in case a plugin imported numpy first.
for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")
