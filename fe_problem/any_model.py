"""One loader for every kind of model file: a frame model (`femu.model/1`, or a shipped name)
or a matrix model (`femu.matrix-model/1`), told apart by the file's `format`."""

from __future__ import annotations

from pathlib import Path

from .jsonutil import read_json_file
from .matrix_model import MATRIX_FORMAT, MatrixModel, matrix_model_from_dict
from .model import FrameModel, ModelFileError, load_model, model_from_dict, shipped_models


def load_any_model(name_or_path) -> FrameModel | MatrixModel:
    """A FrameModel (a shipped name such as ``"hframe"``, or a model file) or a MatrixModel (a
    matrix manifest), by the file's `format` field; a FrameModel or MatrixModel is returned as
    it is. Errors as the two readers give them (ModelFileError, MatrixModelError, both
    ValueError; FileNotFoundError)."""
    if isinstance(name_or_path, (FrameModel, MatrixModel)):
        return name_or_path
    if str(name_or_path) in shipped_models() and not Path(name_or_path).suffix:
        return load_model(name_or_path)
    path = Path(name_or_path)
    if not path.exists():
        return load_model(name_or_path)  # its FileNotFoundError names the shipped models
    d = read_json_file(path, ModelFileError)
    # any version of the matrix format goes to its reader, which names the version it reads
    if isinstance(d, dict) and str(d.get("format", "")).startswith(MATRIX_FORMAT.split("/")[0] + "/"):
        return matrix_model_from_dict(d, source=str(path))
    return model_from_dict(d, source=str(path))


__all__ = ["load_any_model"]
