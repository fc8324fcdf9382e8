"""femu: the application around femu-bench (the `femu` command, studies, reports, reproduce).

Layers, each importing only those below it: femu (this package) -> adapters (optimizer plugins,
registry, budget harness) -> fe_problem (physics, data, the updating problem, diagnosis).
"""

from fe_problem import _threads  # noqa: F401  (one BLAS thread: before numpy loads)
