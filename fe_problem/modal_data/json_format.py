"""The JSON modal-data file (format ``femu.modal-data/1``, docs/modal-data.md): validation
of its parsed content and the dictionary written back."""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from ..dofs import SPATIAL
from ..jsonutil import check_keys
from ..model.validate import is_number, shown
from .types import DATA_FORMAT, DataFileError, ModalData


#: The frequencies a measured mode may have (Hz): a value outside is a unit error or a typo.
FREQUENCY_RANGE_HZ = (1e-6, 1e9)
#: The most modes and measured coordinates a data file may hold (a modal test has far fewer).
MAX_MODES, MAX_DOFS = 10_000, 100_000
#: The keys of the file and of one mode (shared/formats/modal-data.md); any other is refused
DATA_KEYS = ("format", "model", "dofs", "modes", "meta")
MODE_KEYS = ("frequency_hz", "shape", "frequency_std_hz", "shape_std")


def _is_int(x) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def _err(source: str, msg: str) -> DataFileError:
    return DataFileError(f"{source}: {msg}")


def modal_data_from_dict(d: Any, source: str = "<memory>") -> ModalData:
    """Validate the parsed JSON of a modal-data file; errors name the file and the field."""
    if not isinstance(d, dict):
        raise _err(source, "the file must hold a JSON object")
    check_keys(d, DATA_KEYS, source, DataFileError)
    for key in ("format", "model", "dofs", "modes"):
        if key not in d:
            raise _err(source, f"missing field '{key}'")
    if d["format"] != DATA_FORMAT:
        raise _err(source, f"field 'format' must be {DATA_FORMAT!r}, got {d['format']!r}")
    if d["model"] is not None and (not isinstance(d["model"], str) or not d["model"]):
        raise _err(source, "field 'model' must be a model name or a path (or null: data that name no model)")
    dofs = []
    if not isinstance(d["dofs"], list) or not d["dofs"]:
        raise _err(source, "field 'dofs' must be a non-empty list of [node id, direction] (or of row numbers, for "
                           "a model given as matrices with a count of DOFs)")
    if len(d["dofs"]) > MAX_DOFS:
        raise _err(source, f"field 'dofs': {len(d['dofs'])} coordinates are more than the {MAX_DOFS} a data file may hold")
    rows = _is_int(d["dofs"][0])  # row numbers of a matrix model (matrix-model.md), else labels
    for i, x in enumerate(d["dofs"]):
        if rows:
            if not _is_int(x) or x < 1:
                raise _err(source, f"field 'dofs'[{i}]: expected a row number >= 1 (as entry 0 is), got {shown(x)}")
            dofs.append(x)
            continue
        if not (isinstance(x, list) and len(x) == 2 and isinstance(x[0], int) and not isinstance(x[0], bool)):
            raise _err(source, f"field 'dofs'[{i}]: expected [node id, direction], got {shown(x)}")
        if not isinstance(x[1], str) or x[1] not in SPATIAL:
            raise _err(source, f"field 'dofs'[{i}]: unknown direction {shown(x[1])}, use one of {list(SPATIAL)}")
        dofs.append((x[0], x[1]))
    if len(set(dofs)) != len(dofs):
        raise _err(source, "field 'dofs' lists a coordinate twice")
    modes = d["modes"]
    if not isinstance(modes, list) or not modes:
        raise _err(source, "field 'modes' must be a non-empty list")
    if len(modes) > MAX_MODES:
        raise _err(source, f"field 'modes': {len(modes)} modes are more than the {MAX_MODES} a data file may hold")
    freqs = np.empty(len(modes))
    shapes = np.full((len(dofs), len(modes)), np.nan)
    freq_std = np.full(len(modes), np.nan)
    shape_std = np.full((len(dofs), len(modes)), np.nan)
    for k, mode in enumerate(modes):
        where = f"field 'modes'[{k}]"
        if not isinstance(mode, dict) or "frequency_hz" not in mode:
            raise _err(source, f"{where}: missing 'frequency_hz'")
        check_keys(mode, MODE_KEYS, f"{source}: {where}", DataFileError)
        f = mode["frequency_hz"]
        if not is_number(f) or f <= 0:
            raise _err(source, f"{where}.frequency_hz: must be a finite number > 0, got {shown(f)}")
        if not FREQUENCY_RANGE_HZ[0] <= f <= FREQUENCY_RANGE_HZ[1]:
            raise _err(source, f"{where}.frequency_hz: {f:g} Hz is outside the range [{FREQUENCY_RANGE_HZ[0]:g}, "
                               f"{FREQUENCY_RANGE_HZ[1]:g}] Hz a measured mode may have")
        freqs[k] = f
        freq_std[k], shape_std[:, k] = _deviations(mode, len(dofs), source, where)
        s = mode.get("shape")
        if s is None:
            continue
        if not isinstance(s, list) or len(s) != len(dofs):
            n = len(s) if isinstance(s, list) else type(s).__name__
            raise _err(source, f"{where}.shape: needs {len(dofs)} numbers (one per 'dofs' entry), got {n}")
        for j, v in enumerate(s):
            if not is_number(v):
                raise _err(source, f"{where}.shape[{j}]: must be a finite number, got {shown(v)}")
        if not any(s):
            raise _err(source, f"{where}.shape: all zeros")
        shapes[:, k] = s
    if np.any(np.diff(freqs) < 0):
        k = int(np.argmax(np.diff(freqs) < 0))
        raise _err(source, f"field 'modes': frequencies must ascend, mode {k + 1} ({freqs[k + 1]} Hz) "
                           f"comes after {freqs[k]} Hz")
    for k in range(1, len(modes)):
        same_shape = np.array_equal(shapes[:, k], shapes[:, k - 1], equal_nan=True)
        if freqs[k] == freqs[k - 1] and same_shape:
            warnings.warn(f"{source}: field 'modes'[{k - 1}] and [{k}] are the same mode given twice (equal "
                          "frequency and shape)")
    meta = d.get("meta", {})
    if not isinstance(meta, dict):
        raise _err(source, "field 'meta' must be an object")
    return ModalData(d["model"], tuple(dofs), freqs, shapes, meta, source, freq_std, shape_std)


def _deviations(mode: dict, n_dofs: int, source: str, where: str) -> tuple[float, np.ndarray]:
    """A mode's optional `frequency_std_hz` (> 0) and `shape_std` (one number > 0 or one per
    dof, only beside a shape), NaN where absent."""
    fs = mode.get("frequency_std_hz")
    if fs is None:
        fs = np.nan
    elif not is_number(fs) or fs <= 0:
        raise _err(source, f"{where}.frequency_std_hz: must be a finite number > 0, got {shown(fs)}")
    ss = mode.get("shape_std")
    if ss is None:
        return float(fs), np.full(n_dofs, np.nan)
    if mode.get("shape") is None:
        raise _err(source, f"{where}.shape_std: given for a mode without a shape")
    values = ss if isinstance(ss, list) else [ss] * n_dofs
    if isinstance(ss, list) and len(ss) != n_dofs:
        raise _err(source, f"{where}.shape_std: needs one number or {n_dofs} (one per 'dofs' entry), got {len(ss)}")
    for j, v in enumerate(values):
        if not is_number(v) or v <= 0:
            at = f"[{j}]" if isinstance(ss, list) else ""
            raise _err(source, f"{where}.shape_std{at}: must be a finite number > 0, got {shown(v)}")
    return float(fs), np.asarray(values, dtype=float)


def modal_data_to_dict(data: ModalData) -> dict:
    """The JSON-ready dictionary of a modal-data file."""
    modes = []
    for k in range(data.n_modes):
        col = data.shapes[:, k]
        mode = {"frequency_hz": float(data.frequencies_hz[k]),
                "shape": None if np.isnan(col).any() else [float(v) for v in col]}
        if not np.isnan(data.frequency_std_hz[k]):
            mode["frequency_std_hz"] = float(data.frequency_std_hz[k])
        std = data.shape_std[:, k]
        if mode["shape"] is not None and not np.isnan(std).any():
            mode["shape_std"] = float(std[0]) if np.all(std == std[0]) else [float(v) for v in std]
        modes.append(mode)
    return {"format": DATA_FORMAT, "model": data.model,
            "dofs": [list(x) if isinstance(x, tuple) else int(x) for x in data.dofs],
            "modes": modes, "meta": data.meta}
