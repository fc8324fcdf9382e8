"""femu-bench physics: frame FE models (planar today), modal analysis, correlation, measured data,
and the FE model-updating problem. Knows nothing of optimizers."""

from . import _threads  # noqa: F401  (one BLAS thread: before numpy loads)
from .correlation import comac, frequency_errors_pct, mac, pair_modes
from .modal_data import (DataFileError, ModalData, load_modal_data, paper_table, save_modal_data,
                   synthetic_measurement)
from .modal import ModalResult, modal_analysis
from .model import (FrameModel, ModelFileError, add_mass, crack_element, load_model, regular_frame, regular_frame_3d,
                    release_element_end, save_model, split_element, split_elements, with_formulation)
from .assembly import AffineModel
from .parameters import Parameter, element_moduli
from .problem import CorrelationReport, UpdatingProblem
from .diagnosis import Diagnosis, diagnose
from .suite import SuiteProblem, select_suite, suite_entry, suite_ids, suite_problem

__all__ = [
    "AffineModel", "CorrelationReport", "Diagnosis", "diagnose", "DataFileError", "FrameModel", "ModalData", "ModalResult",
    "ModelFileError", "Parameter", "UpdatingProblem", "add_mass", "comac", "crack_element", "element_moduli",
    "frequency_errors_pct", "load_modal_data", "load_model", "mac", "modal_analysis", "pair_modes",
    "paper_table", "regular_frame", "regular_frame_3d", "release_element_end", "save_modal_data", "save_model", "split_element",
    "split_elements",
    "synthetic_measurement", "with_formulation", "SuiteProblem", "select_suite", "suite_entry", "suite_ids",
    "suite_problem",
]

# From FRFs to modal data (issue 12): the synthetic test rig, FRF files, identification
from .identification import FRFFileError, FRFSet, Identification, identify, read_frf, synthetic_frf  # noqa: E402

__all__ += ["FRFFileError", "FRFSet", "Identification", "identify", "read_frf", "synthetic_frf"]
