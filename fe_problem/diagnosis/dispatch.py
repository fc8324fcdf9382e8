"""`diagnose(model, data)`: the diagnosis of any model a data file can name, a frame model (core.py)
or a model given as matrices (matrix.py), told apart by the model's type (`load_any_model`)."""

from __future__ import annotations

from ..any_model import load_any_model
from ..matrix_model import MatrixModel
from ..modal_data import ModalData, load_modal_data
from .core import ALPHA, MAX_CAUSES, N_FIT, diagnose as diagnose_frame
from .matrix import diagnose_matrix
from .record import Diagnosis


def diagnose(model, data: ModalData | str, freq_noise: float | None = None, shape_noise: float | None = None,
             kinds=None, n_fit: int | None = N_FIT, alpha: float = ALPHA, max_causes: int = MAX_CAUSES,
             evidence: str = "laplace", keep_faulty: bool = False) -> Diagnosis:
    """Diagnose what `model` (a FrameModel, a MatrixModel, a shipped name, a model file or a matrix
    manifest; None: the data's own model) misses in `data`: `core.diagnose` for a frame model
    (every argument as documented there), `matrix.diagnose_matrix` for a model given as matrices
    (one local cause: `max_causes` does not apply)."""
    data = load_modal_data(data)
    model = data.load_model() if model is None else load_any_model(model)
    if isinstance(model, MatrixModel):
        return diagnose_matrix(model, data, freq_noise, shape_noise, kinds, n_fit, alpha, evidence, keep_faulty)
    return diagnose_frame(model, data, freq_noise, shape_noise, kinds, n_fit, alpha, max_causes, evidence, keep_faulty)


__all__ = ["diagnose"]
