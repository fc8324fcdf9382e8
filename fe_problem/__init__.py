"""femu-bench physics: frame FE models (planar today), modal analysis, correlation, measured data,
and the FE model-updating problem. Knows nothing of optimizers.

The public names are loaded on first use (PEP 562 `__getattr__`): `import fe_problem` costs no
scipy and no diagnosis, so that `femu --help` answers at once (issue 25); `from fe_problem
import X` and `fe_problem.X` work as before.
"""

from __future__ import annotations

import importlib
import importlib.util

import os as _os

# An optimizer's worker process (adapters.sandbox_worker) and every process it starts carry this
# mark: the FE model, its data and the suite's hidden truths are not theirs to build.
if _os.environ.get("FEMU_OPTIMIZER_PROCESS"):
    raise ImportError("fe_problem: not available in an optimizer's process (the FE model, its data and the suite "
                      "stay with the evaluating process; an optimizer sees only its objective)", name="fe_problem")


def _have(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except ImportError:  # an import system that refuses the name outright
        return False


# the two libraries every module needs, looked for (not imported: `femu --help` stays fast)
for _name in ("numpy", "scipy"):
    if not _have(_name):
        raise ImportError(f"fe_problem needs {_name!r}, which this Python does not have: install femu-bench into an "
                          "environment (python3 -m venv .venv && .venv/bin/pip install -e .) and run its Python "
                          "(.venv/bin/python, or activate it: . .venv/bin/activate)", name=_name)

from . import _threads  # noqa: F401,E402  (one BLAS thread: before numpy loads)

#: public name -> the submodule that defines it
_WHERE = {
    **dict.fromkeys(("comac", "frequency_errors_pct", "mac", "pair_modes"), "correlation"),
    **dict.fromkeys(("DataFileError", "ModalData", "load_modal_data", "paper_table", "save_modal_data",
                     "synthetic_measurement"), "modal_data"),
    **dict.fromkeys(("ModalResult", "modal_analysis"), "modal"),
    **dict.fromkeys(("FrameModel", "ModelFileError", "add_mass", "crack_element", "load_model", "regular_frame",
                     "regular_frame_3d", "release_element_end", "save_model", "split_element", "split_elements", "with_formulation"),
                    "model"),
    "AffineModel": "assembly",
    # models given as matrices (issue 35): the manifest, its solver interface, one loader for any model
    **dict.fromkeys(("MatrixModel", "MatrixModelError", "MatrixSystem", "load_matrix_model", "save_matrix_model"),
                    "matrix_model"),
    "load_any_model": "any_model",
    **dict.fromkeys(("Parameter", "element_moduli"), "parameters"),
    **dict.fromkeys(("CorrelationReport", "UpdatingProblem"), "problem"),
    **dict.fromkeys(("Diagnosis", "diagnose"), "diagnosis"),
    **dict.fromkeys(("SuiteProblem", "select_suite", "suite_entry", "suite_ids", "suite_problem"), "suite"),
    # From FRFs to modal data (issue 12): the synthetic test rig, FRF files, identification
    **dict.fromkeys(("FRFFileError", "FRFSet", "Identification", "identify", "read_frf", "synthetic_frf"),
                    "identification"),
    # From ambient records to modal data (issue 37)
    **dict.fromkeys(("TimeSeriesError", "identify_ambient", "read_timeseries"), "identification"),
}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    """A public name (imported from its submodule on first use), or a submodule."""
    where = _WHERE.get(name)
    if where is not None:
        value = getattr(importlib.import_module(f".{where}", __name__), name)
        globals()[name] = value
        return value
    try:
        return importlib.import_module(f".{name}", __name__)
    except ModuleNotFoundError as exc:
        if exc.name != f"{__name__}.{name}":
            raise
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None


def __dir__():
    return sorted(set(globals()) | set(_WHERE))
