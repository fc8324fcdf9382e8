"""Models given as matrices (`femu.matrix-model/1`, docs/matrix-model.md): the `MatrixModel`
type (types.py), the manifest's reader and writer (io.py) and `MatrixSystem`, its solver
interface (system.py, the same methods as `assembly.AffineModel`)."""

from .io import load_matrix_model, matrix_model_from_dict, save_matrix_model
from .system import MatrixSystem
from .types import MATRIX_FORMAT, MatrixModel, MatrixModelError, MatrixParameter, MatrixTerm

__all__ = ["MATRIX_FORMAT", "MatrixModel", "MatrixModelError", "MatrixParameter", "MatrixSystem", "MatrixTerm",
           "load_matrix_model", "matrix_model_from_dict", "save_matrix_model"]
