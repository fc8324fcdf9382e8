"""Thread settings of the BLAS under numpy for the plugin layer; imported before numpy.

The same rule as fe_problem._threads, kept here because an optimizer's worker process
(adapters.sandbox_worker) must not import the FE package at all."""

# Many small eigen-solves run far slower with multi-threaded BLAS, and the processes of a study
# compete for the cores: one BLAS thread per process unless the user says otherwise.
import os as _os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")
