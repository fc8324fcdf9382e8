"""A user's own updating problem: a model file, measured modes and (optionally) a parameter
file, as the balanced `UpdatingProblem` that `femu update` fits and `femu study --model`
benchmarks optimizers on.

`load_update_model` is the one place a user's model is read (a frame model file today; a new
model type is one branch here). A problem's source (`ProblemSource`: the files' paths and their
SHA-256) is what a study writes and a run record carries, so that the problem can be rebuilt
and a changed file is noticed (`problem_from_source`).
"""

from __future__ import annotations

import hashlib
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

#: The format of a problem source file (written by `femu study --model` into its store).
SOURCE_FORMAT = "femu.user-problem/1"
#: The default parameters of a frame model without a parameter file: each element's modulus
#: within +- this fraction of its own.
DEFAULT_SPREAD = 0.3


def load_update_model(path):
    """The model at `path` (or a shipped model's name): the one place `femu update` and
    `femu study --model` read a model (a frame model file, `femu.model/1`, or a matrix model's
    manifest, `femu.matrix-model/1`, told apart by the file's `format`)."""
    from .any_model import load_any_model

    return load_any_model(path)


def default_parameters(model):
    """The parameters used without a parameter file, and the sentence a report says of them."""
    from .matrix_model import MatrixModel
    from .model import FrameModel
    from .parameters import frame_default_parameters

    if isinstance(model, MatrixModel):
        if not model.parameters:
            raise ValueError(f"{model.source or model.name}: no term has lower and upper: a matrix model's updating "
                             "parameters are the terms of its manifest with bounds")
        return model.parameters, "the manifest's parameters (its terms with lower and upper)"
    if isinstance(model, FrameModel):
        return (frame_default_parameters(model, DEFAULT_SPREAD),
                f"no parameter file: each element's modulus within +-{DEFAULT_SPREAD:.0%} of the model's own")
    raise ValueError(f"model {getattr(model, 'name', model)!r}: give its parameters with --parameters")


def file_hash(path) -> str | None:
    """The SHA-256 of a file's bytes (None for a shipped name that is not a file)."""
    p = Path(path)
    return hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else None


def model_hash(path) -> str | None:
    """The SHA-256 of a model file, and for a matrix manifest of its matrix files too (the
    manifest's bytes, then each term's file's in manifest order): a changed matrix changes the
    problem as a changed manifest does. None for a shipped name that is not a file."""
    import json

    p = Path(path)
    if not p.is_file():
        return None
    raw = p.read_bytes()
    h = hashlib.sha256(raw)
    try:
        d = json.loads(raw)
    except ValueError:
        return h.hexdigest()
    if isinstance(d, dict) and str(d.get("format", "")).startswith("femu.matrix-model/"):
        for t in list(d.get("stiffness") or []) + list(d.get("mass") or []):
            f = p.parent / str(t.get("file", "")) if isinstance(t, dict) else None
            if f is not None and f.is_file():
                h.update(f.read_bytes())
    return h.hexdigest()


def user_problem(model_path, data_path, parameters_path=None, hold_out: int = 0, name: str | None = None):
    """(problem, full data, held-out indices, the parameter note): the balanced updating problem
    of a user's model and data, the last `hold_out` measured modes kept out of the fit."""
    from .matrix_model import MatrixModel
    from .modal_data import load_modal_data
    from .parameter_file import load_parameters
    from .problem import UpdatingProblem

    model = load_update_model(model_path)
    data = load_modal_data(data_path)
    if parameters_path is not None and isinstance(model, MatrixModel):
        raise ValueError(f"--parameters {parameters_path}: a matrix model carries its parameters in its manifest "
                         f"({model.source}: the terms with lower and upper); give no parameter file")
    if parameters_path is not None:
        parameters, note = load_parameters(parameters_path, model), f"parameters from {parameters_path}"
    else:
        parameters, note = default_parameters(model)
    m = data.n_modes
    if not 0 <= hold_out < m:
        raise ValueError(f"--hold-out {hold_out}: must be between 0 and {m - 1} (the data hold {m} modes; "
                         "at least one is fitted)")
    held = np.arange(m - hold_out, m)
    # room to pair the held-out modes too (`UpdatingProblem` caps it at the model's elastic modes)
    problem = UpdatingProblem(model, data.subset(np.arange(m - hold_out)) if hold_out else data, parameters,
                              objective="balanced", n_model_modes=m + 4,
                              name=name or f"{Path(str(model_path)).stem}:{Path(str(data_path)).stem}")
    return problem, data, held, note


@dataclass(frozen=True)
class ProblemSource:
    """Where a user's problem comes from: the paths (absolute; relative to the source file in a
    store's copy, `relative_to`) or shipped names of the model, the
    data and the parameter file (None: the default parameters) and each file's SHA-256 (the
    model's through `model_hash`: a matrix manifest's with its matrix files)."""

    model: str
    data: str
    parameters: str | None
    model_sha256: str | None
    data_sha256: str | None
    parameters_sha256: str | None

    @classmethod
    def of(cls, model, data, parameters=None) -> "ProblemSource":
        """The source of the files given (paths made absolute; a shipped name kept)."""
        def where(p):
            return None if p is None else (str(Path(p).resolve()) if Path(p).is_file() else str(p))
        return cls(where(model), where(data), where(parameters), model_hash(model), file_hash(data),
                   None if parameters is None else file_hash(parameters))

    def to_dict(self) -> dict:
        return dict(asdict(self), format=SOURCE_FORMAT)

    def relative_to(self, folder) -> "ProblemSource":
        """The source with each file's path relative to `folder` (the folder its source file is
        written to, in a study's store), so that a store moved together with the user's files keeps
        its problem; a shipped name is kept as it is. `source_from_dict` resolves them back."""
        import os

        def rel(p):
            return p if p is None or not Path(p).is_absolute() else os.path.relpath(p, Path(folder).resolve())
        return replace(self, model=rel(self.model), data=rel(self.data), parameters=rel(self.parameters))

    @property
    def name(self) -> str:
        """The problem's name: the model's and data's stems and a hash of the three files."""
        h = hashlib.sha256("|".join(str(v) for v in (self.model_sha256, self.data_sha256,
                                                      self.parameters_sha256)).encode()).hexdigest()[:8]
        return f"{Path(self.model).stem}:{Path(self.data).stem}:{h}"


def source_from_dict(d, where: str = "<memory>") -> ProblemSource:
    """A `ProblemSource` from its dictionary; ValueError naming `where` and the field."""
    keys = ("format", "model", "data", "parameters", "model_sha256", "data_sha256", "parameters_sha256")
    if not isinstance(d, dict) or d.get("format") != SOURCE_FORMAT or set(d) != set(keys):
        raise ValueError(f"{where}: not a {SOURCE_FORMAT} problem source (fields {', '.join(keys)})")
    src = ProblemSource(**{k: d[k] for k in keys if k != "format"})
    if where == "<memory>":
        return src
    folder = Path(where).resolve().parent

    def resolved(p):  # a path relative to the source file's folder (`relative_to`); a shipped name kept
        if p is None or Path(p).is_absolute():
            return p
        at = folder / p
        return str(at.resolve()) if at.exists() or Path(p).suffix else p
    return replace(src, model=resolved(src.model), data=resolved(src.data), parameters=resolved(src.parameters))


def problem_from_source(src: ProblemSource):
    """The problem of a source; ValueError when a file has changed since (its SHA-256 differs)."""
    for what in ("model", "data", "parameters"):
        path, recorded = getattr(src, what), getattr(src, f"{what}_sha256")
        if path is None or recorded is None:
            continue
        if not Path(path).is_file():
            raise ValueError(f"{path}: the {what} file of this study's problem is not there (recorded with SHA-256 "
                             f"{recorded[:12]}...; a problem source names its files relative to itself: move the "
                             "store and the files together, or start a new store)")
        if (model_hash(path) if what == "model" else file_hash(path)) != recorded:
            raise ValueError(f"{path}: the {what} file has changed since the study recorded it (SHA-256 "
                             f"{recorded[:12]}...): its runs are of another problem; use a new store")
    problem = user_problem(src.model, src.data, src.parameters, name=src.name)[0]
    problem.source = src
    return problem


__all__ = ["DEFAULT_SPREAD", "ProblemSource", "SOURCE_FORMAT", "default_parameters", "file_hash", "model_hash",
           "load_update_model", "problem_from_source", "source_from_dict", "user_problem"]
