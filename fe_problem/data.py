"""Measured modal data: the JSON file of docs/modal-data-format.md, the paper's dataset,
and synthetic measurements.

`ModalData` holds frequencies (Hz), shapes at the measured DOFs (NaN columns where only the
frequency was measured) and the name of the model it belongs to. UFF dataset 55 is read
and written in uff.py.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .model import DATA_DIR, DIRECTIONS, FrameModel, load_model, shipped_models

DATA_FORMAT = "femu.modal-data/1"


class DataFileError(ValueError):
    """A measured-data file that breaks its format; the message names the file and field."""


@dataclass(frozen=True, eq=False)
class ModalData:
    """Measured modes of one structure.

    model: a shipped model name or a model file path; dofs: the measured coordinates
    (node id, direction); frequencies_hz: (m,) ascending; shapes: (len(dofs), m), a column of
    NaN where only the frequency is known. A shape's sign and scale carry no meaning.
    """

    model: str
    dofs: tuple[tuple[int, str], ...]
    frequencies_hz: np.ndarray
    shapes: np.ndarray
    meta: dict = field(default_factory=dict)
    source: str = "<memory>"

    @property
    def n_modes(self) -> int:
        return int(self.frequencies_hz.shape[0])

    @property
    def has_shape(self) -> np.ndarray:
        """(m,) True where the mode's shape was measured."""
        return ~np.isnan(self.shapes).any(axis=0)

    def subset(self, modes) -> "ModalData":
        """The data restricted to some modes (indices), e.g. to hold modes out."""
        modes = np.asarray(modes, dtype=int)
        return ModalData(self.model, self.dofs, self.frequencies_hz[modes], self.shapes[:, modes],
                         dict(self.meta), self.source)

    def without_shapes(self) -> "ModalData":
        return ModalData(self.model, self.dofs, self.frequencies_hz.copy(),
                         np.full_like(self.shapes, np.nan), dict(self.meta), self.source)

    def load_model(self) -> FrameModel:
        """The model this data belongs to (name, or path relative to the data file)."""
        if self.model in shipped_models():
            return load_model(self.model)
        path = Path(self.model)
        if not path.is_absolute() and self.source not in ("<memory>", ""):
            path = Path(self.source).parent / path
        return load_model(path)

    def check_model(self, model: FrameModel) -> None:
        """Raise DataFileError if a measured DOF does not exist in `model`."""
        ids = set(model.node_ids)
        for i, (node, d) in enumerate(self.dofs):
            if node not in ids:
                raise DataFileError(f"{self.source}: field 'dofs'[{i}]: node {node} is not in model {model.name!r}")


def _err(source: str, msg: str) -> DataFileError:
    return DataFileError(f"{source}: {msg}")


def modal_data_from_dict(d: Any, source: str = "<memory>") -> ModalData:
    """Validate the parsed JSON of a modal-data file; errors name the file and the field."""
    if not isinstance(d, dict):
        raise _err(source, "the file must hold a JSON object")
    for key in ("format", "model", "dofs", "modes"):
        if key not in d:
            raise _err(source, f"missing field '{key}'")
    if d["format"] != DATA_FORMAT:
        raise _err(source, f"field 'format' must be {DATA_FORMAT!r}, got {d['format']!r}")
    if not isinstance(d["model"], str) or not d["model"]:
        raise _err(source, "field 'model' must be a model name or a path")
    dofs = []
    if not isinstance(d["dofs"], list) or not d["dofs"]:
        raise _err(source, "field 'dofs' must be a non-empty list of [node id, direction]")
    for i, x in enumerate(d["dofs"]):
        if not (isinstance(x, list) and len(x) == 2 and isinstance(x[0], int) and not isinstance(x[0], bool)):
            raise _err(source, f"field 'dofs'[{i}]: expected [node id, direction], got {x!r}")
        if x[1] not in DIRECTIONS:
            raise _err(source, f"field 'dofs'[{i}]: unknown direction {x[1]!r}, use one of {list(DIRECTIONS)}")
        dofs.append((x[0], x[1]))
    if len(set(dofs)) != len(dofs):
        raise _err(source, "field 'dofs' lists a coordinate twice")
    modes = d["modes"]
    if not isinstance(modes, list) or not modes:
        raise _err(source, "field 'modes' must be a non-empty list")
    freqs = np.empty(len(modes))
    shapes = np.full((len(dofs), len(modes)), np.nan)
    for k, mode in enumerate(modes):
        where = f"field 'modes'[{k}]"
        if not isinstance(mode, dict) or "frequency_hz" not in mode:
            raise _err(source, f"{where}: missing 'frequency_hz'")
        f = mode["frequency_hz"]
        if isinstance(f, bool) or not isinstance(f, (int, float)) or not math.isfinite(f) or f <= 0:
            raise _err(source, f"{where}.frequency_hz: must be a finite number > 0, got {f!r}")
        freqs[k] = f
        s = mode.get("shape")
        if s is None:
            continue
        if not isinstance(s, list) or len(s) != len(dofs):
            n = len(s) if isinstance(s, list) else type(s).__name__
            raise _err(source, f"{where}.shape: needs {len(dofs)} numbers (one per 'dofs' entry), got {n}")
        for j, v in enumerate(s):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise _err(source, f"{where}.shape[{j}]: must be a finite number, got {v!r}")
        if not any(s):
            raise _err(source, f"{where}.shape: all zeros")
        shapes[:, k] = s
    if np.any(np.diff(freqs) < 0):
        k = int(np.argmax(np.diff(freqs) < 0))
        raise _err(source, f"field 'modes': frequencies must ascend, mode {k + 1} ({freqs[k + 1]} Hz) "
                           f"comes after {freqs[k]} Hz")
    meta = d.get("meta", {})
    if not isinstance(meta, dict):
        raise _err(source, "field 'meta' must be an object")
    return ModalData(d["model"], tuple(dofs), freqs, shapes, meta, source)


def modal_data_to_dict(data: ModalData) -> dict:
    """The JSON-ready dictionary of a modal-data file."""
    modes = []
    for k in range(data.n_modes):
        col = data.shapes[:, k]
        modes.append({"frequency_hz": float(data.frequencies_hz[k]),
                      "shape": None if np.isnan(col).any() else [float(v) for v in col]})
    return {"format": DATA_FORMAT, "model": data.model, "dofs": [list(x) for x in data.dofs],
            "modes": modes, "meta": data.meta}


def shipped_datasets() -> tuple[str, ...]:
    return tuple(sorted(p.name[: -len(".modal.json")] for p in DATA_DIR.glob("*.modal.json")))


def load_modal_data(name_or_path: str | Path | ModalData) -> ModalData:
    """Read measured modal data: a shipped dataset (``"paper"``), a JSON file, or a UFF file
    (``.uff``/``.unv``, dataset 55). Unknown nodes of the named model are refused."""
    if isinstance(name_or_path, ModalData):
        return name_or_path
    path = Path(name_or_path)
    if not path.suffix and str(name_or_path) in shipped_datasets():
        path = DATA_DIR / f"{name_or_path}.modal.json"
    if not path.exists():
        raise FileNotFoundError(f"no data file {str(name_or_path)!r} and no shipped dataset of that name "
                                f"(shipped: {', '.join(shipped_datasets())})")
    if path.suffix.lower() in (".uff", ".unv"):
        from .uff import read_uff55
        data = read_uff55(path)
    else:
        try:
            raw = json.loads(path.read_text())
        except json.JSONDecodeError as exc:
            raise DataFileError(f"{path}: not valid JSON ({exc})") from None
        data = modal_data_from_dict(raw, source=str(path))
    try:
        model = data.load_model()
    except (FileNotFoundError, ValueError) as exc:
        raise DataFileError(f"{path}: field 'model': {exc}") from None
    data.check_model(model)
    return data


def save_modal_data(data: ModalData, path: str | Path) -> Path:
    """Write JSON (``.json``) or UFF dataset 55 (``.uff``/``.unv``)."""
    path = Path(path)
    if path.suffix.lower() in (".uff", ".unv"):
        from .uff import write_uff55
        write_uff55(data, path)
    else:
        path.write_text(json.dumps(modal_data_to_dict(data), indent=1) + "\n")
    return path


def paper_table() -> dict:
    """Table 1 of the paper and the figures quoted in its text (shipped with the 'paper' data)."""
    return load_modal_data("paper").meta["table1"]


def synthetic_measurement(model: FrameModel | str, n_modes: int = 8, dofs=None, freq_noise: float = 0.0,
                          shape_noise: float = 0.0, seed: int | None = 0, random_sign_scale: bool = True,
                          model_name: str | None = None, with_shapes: bool = True,
                          parameters=(), theta=None) -> ModalData:
    """Synthetic 'measured' data from any model (with or without extra effects).

    Frequencies get relative Gaussian noise (std `freq_noise`, e.g. 0.002 for 0.2 %); shape
    entries get Gaussian noise of std `shape_noise` times the mode's RMS at the measured DOFs;
    each shape then gets a random sign and a log-uniform scale in [0.1, 10]. Modes are
    re-sorted by frequency after the noise. `model_name` is what the data says it belongs to
    (default: the model's name; a truth model with a hidden effect names the nominal model).
    """
    from .modal import modal_analysis

    model = load_model(model)
    rng = np.random.default_rng(seed)
    dofs = tuple(model.measured_dofs if dofs is None else (tuple(d) for d in dofs))
    if not dofs:
        raise ValueError(f"model {model.name!r} lists no measured DOFs: pass dofs=")
    res = modal_analysis(model, n_modes, parameters=parameters, theta=theta)
    freqs = res.frequencies_hz * (1.0 + freq_noise * rng.standard_normal(n_modes))
    shapes = res.at(dofs).copy()
    rms = np.sqrt(np.mean(shapes**2, axis=0))
    shapes += shape_noise * rms * rng.standard_normal(shapes.shape)
    if random_sign_scale:
        shapes *= rng.choice([-1.0, 1.0], n_modes) * np.exp(rng.uniform(np.log(0.1), np.log(10.0), n_modes))
    order = np.argsort(freqs, kind="stable")
    if not with_shapes:
        shapes[:] = np.nan
    meta = {"source": "synthetic", "truth_model": model.name, "freq_noise": freq_noise,
            "shape_noise": shape_noise, "seed": seed}
    return ModalData(model_name or model.name, dofs, freqs[order], shapes[:, order], meta)
