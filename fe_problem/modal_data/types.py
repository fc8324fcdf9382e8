"""`ModalData`: measured frequencies (Hz), shapes at the measured DOFs (NaN columns where only
the frequency was measured) and the name of the model the data belong to."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..any_model import load_any_model
from ..model import FrameModel, load_model, shipped_models
from ..model.validate import shown

#: The format tag of a JSON modal-data file.
DATA_FORMAT = "femu.modal-data/1"
#: The noise assumed where a mode states no deviation (the diagnosis' convention,
#: diagnosis/residuals.py): a frequency's std as a fraction of it, a shape entry's std as a
#: fraction of the largest |entry| of its shape.
DEFAULT_FREQ_NOISE, DEFAULT_SHAPE_NOISE = 0.002, 0.02


class DataFileError(ValueError):
    """A measured-data file that breaks its format; the message names the file and field."""


def model_named(model: str, source: str):
    """The model a data file names: a shipped model, or a model file or matrix manifest path
    relative to the data file `source` (a FrameModel or a MatrixModel, `load_any_model`;
    FileNotFoundError / ModelFileError / MatrixModelError as it gives them)."""
    if model in shipped_models():
        return load_model(model)
    path = Path(model)
    if not path.is_absolute() and source not in ("<memory>", ""):
        path = Path(source).parent / path
    return load_any_model(path)


@dataclass(frozen=True, eq=False)
class ModalData:
    """Measured modes of one structure.

    model: a shipped model name, a model file or matrix manifest path, or None (an ambient
    identification without a model: the channels' labels, mapped when a model is given); dofs: the measured
    coordinates (node id, direction), or 1-based row numbers (int) for a matrix model whose DOFs
    are a count; frequencies_hz: (m,) ascending; shapes: (len(dofs), m), a column of
    NaN where only the frequency is known. A shape's sign and scale carry no meaning.
    frequency_std_hz: (m,) the standard deviation of each frequency (Hz), NaN where not stated;
    shape_std: (len(dofs), m) the standard deviation of each shape entry in the units of
    `shapes` as given, NaN where not stated (None for either: none stated).
    """

    model: str | None
    dofs: tuple[tuple[int, str], ...]
    frequencies_hz: np.ndarray
    shapes: np.ndarray
    meta: dict = field(default_factory=dict)
    source: str = "<memory>"
    frequency_std_hz: np.ndarray | None = None
    shape_std: np.ndarray | None = None

    def __post_init__(self) -> None:
        m = self.frequencies_hz.shape[0]
        fs = np.full(m, np.nan) if self.frequency_std_hz is None else np.asarray(self.frequency_std_hz, dtype=float)
        ss = (np.full(self.shapes.shape, np.nan) if self.shape_std is None
              else np.asarray(self.shape_std, dtype=float))
        if fs.shape != (m,) or ss.shape != self.shapes.shape:
            raise ValueError(f"{self.source}: frequency_std_hz must have shape ({m},) and shape_std "
                             f"{self.shapes.shape}, got {fs.shape} and {ss.shape}")
        object.__setattr__(self, "frequency_std_hz", fs)
        object.__setattr__(self, "shape_std", ss)

    @property
    def has_frequency_std(self) -> np.ndarray:
        """(m,) True where the mode's frequency has a stated standard deviation."""
        return ~np.isnan(self.frequency_std_hz)

    @property
    def has_shape_std(self) -> np.ndarray:
        """(m,) True where the mode's shape has a stated standard deviation (every entry)."""
        return self.has_shape & ~np.isnan(self.shape_std).any(axis=0)

    @property
    def n_modes(self) -> int:
        """Number of measured modes."""
        return int(self.frequencies_hz.shape[0])

    @property
    def has_shape(self) -> np.ndarray:
        """(m,) True where the mode's shape was measured."""
        return ~np.isnan(self.shapes).any(axis=0)

    def noise(self, freq_noise: float = DEFAULT_FREQ_NOISE,
              shape_noise: float = DEFAULT_SHAPE_NOISE) -> tuple[np.ndarray, np.ndarray]:
        """The standard deviations (m,) of the frequencies (Hz) and (len(dofs), m) of the shape
        entries (units of `shapes`): the stated ones, else `freq_noise` x the frequency and
        `shape_noise` x the largest |entry| of the mode's shape (NaN where no shape)."""
        sf = np.where(self.has_frequency_std, self.frequency_std_hz, freq_noise * self.frequencies_hz)
        with np.errstate(invalid="ignore"):
            peak = np.nanmax(np.abs(self.shapes), axis=0, initial=0.0)
        ss = np.where(np.isnan(self.shape_std), shape_noise * peak[None, :], self.shape_std)
        return sf, np.where(np.isnan(self.shapes), np.nan, ss)

    def subset(self, modes) -> "ModalData":
        """The data restricted to some modes (indices), e.g. to hold modes out."""
        modes = np.asarray(modes, dtype=int)
        return ModalData(self.model, self.dofs, self.frequencies_hz[modes], self.shapes[:, modes],
                         dict(self.meta), self.source, self.frequency_std_hz[modes], self.shape_std[:, modes])

    def without_shapes(self) -> "ModalData":
        """The data with every shape dropped (frequencies only; their deviations kept)."""
        return ModalData(self.model, self.dofs, self.frequencies_hz.copy(),
                         np.full_like(self.shapes, np.nan), dict(self.meta), self.source,
                         self.frequency_std_hz.copy(), np.full_like(self.shapes, np.nan))

    def load_model(self) -> FrameModel:
        """The model this data belongs to (name, or path relative to the data file); a
        DataFileError when the data name none (give the model: --model)."""
        if self.model is None:
            raise DataFileError(f"{self.source}: the data name no model (identified without one): give the model "
                                "whose nodes the channel labels are (--model)")
        return model_named(self.model, self.source)

    def is_for(self, model: FrameModel) -> bool:
        """Whether this data names `model`: by its name, or as the model file `model` was read
        from (a path relative to the data file). Data that name no model are for any model whose
        DOFs they label (check_model says whether they are)."""
        if self.model is None or self.model == model.name:
            return True
        if self.model in shipped_models():
            return False
        path = Path(self.model)
        if not path.is_absolute() and self.source not in ("<memory>", ""):
            path = Path(self.source).parent / path
        try:
            return bool(model.source) and path.resolve() == Path(model.source).resolve()
        except OSError:
            return False

    def check_model(self, model) -> None:
        """Raise DataFileError if a measured DOF does not exist in `model` (a FrameModel or a
        MatrixModel: row numbers 1..n for a counted one, its [node, direction] labels else)."""
        if not isinstance(model, FrameModel):
            self._check_matrix_model(model)
            return
        if self.dofs and not isinstance(self.dofs[0], tuple):
            raise DataFileError(f"{self.source}: field 'dofs': row numbers are for a model given as matrices with a "
                                f"count of DOFs; model {model.name!r} is a frame: give [node id, direction]")
        ids = set(model.node_ids)
        for i, (node, d) in enumerate(self.dofs):
            if node not in ids:
                raise DataFileError(f"{self.source}: field 'dofs'[{i}]: node {shown(node)} is not in model {model.name!r}")
            if d not in model.layout.names:
                raise DataFileError(f"{self.source}: field 'dofs'[{i}]: unknown direction {d!r}; the nodes of model "
                                    f"{model.name!r} have {list(model.layout.names)}")

    def _check_matrix_model(self, model) -> None:
        for i, d in enumerate(self.dofs):
            if model.row_of(d) is not None:
                continue
            if model.labelled and not isinstance(d, tuple):
                raise DataFileError(f"{self.source}: field 'dofs'[{i}]: {shown(d)} is a row number, but the DOFs of model "
                                    f"{model.name!r} are labelled: give [node, direction]")
            if not model.labelled and isinstance(d, tuple):
                raise DataFileError(f"{self.source}: field 'dofs'[{i}]: model {model.name!r} numbers its DOFs 1.."
                                    f"{model.n_dof}: give row numbers, not {list(d)}")
            what = f"row {d} (1..{model.n_dof})" if not model.labelled else f"DOF {list(d)}"
            raise DataFileError(f"{self.source}: field 'dofs'[{i}]: model {model.name!r} has no {what}")
