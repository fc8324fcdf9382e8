"""Measured modal data as Universal File Format dataset 55 (data at nodes), through pyuff.

What a file holds, as written here and as read:
- one dataset 55 per mode: analysis type 2 (normal mode), real data (data type 2), 6 values
  per node (data characteristic 3: x, y, z, rx, ry, rz); record 8 holds the frequency (Hz),
  modal mass and damping 0 (unknown). Every dataset lists the same nodes in the same order.
- ID line 1 names the model the data belongs to: ``model: hframe`` (a shipped model name or
  a model file path relative to the data file; a bare ID line 1 is read as the name, as the
  UFF dataloader convention puts the model identification there). ID line 2 holds
  ``meta["source"]`` (80 characters at most). Other ``meta`` entries are not stored.
- A node moves only in its model's DOFs (the `DofLayout` of the model ID line 1 names,
  dofs.py; the planar frame: x, y, rz; a space frame: all six): the other values are written
  as 0, and on reading a file with a non-zero value there is refused. Data characteristic 2
  (3 translations) is read too.

Limits of the format, and the choices made:
- Values are written with 6 significant figures (format 6E13.5, fixed by the standard), so
  frequencies and shape entries round-trip to 5e-6 relative.
- A node's unmeasured directions are written as 0 (the standard's rule for reduced DOF
  sets). On reading, the measured DOFs are the (node, direction) entries that are non-zero
  in at least one mode, in file order: node by node, then in the layout's DOF order. The DOF order of a JSON
  file is therefore not kept (nothing depends on it), and a DOF measured as exactly 0 in
  every mode cannot be told from an unmeasured one.
- A mode with no measured shape cannot be written: a dataset 55 *is* a shape, and an all-zero
  dataset would claim a zero shape. `write_uff55` refuses such data (write JSON instead, or
  keep the modes with shapes: ``data.subset(np.flatnonzero(data.has_shape))``).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..dofs import DEFAULT_LAYOUT, SPATIAL, DofLayout
from .json_format import modal_data_from_dict
from .types import DATA_FORMAT, DataFileError, ModalData, model_named

#: the one line a missing pyuff gives (pyuff comes with the 'import' and 'identify' extras)
UFF_EXTRA = "reading or writing a UFF file needs the 'import' extra: pip install 'femu-bench[import]'"


def uff_library(path=None):
    """pyuff, or a DataFileError (a ValueError: one line, exit 2) naming the file and the extra
    that installs it."""
    try:
        import pyuff
    except ImportError:
        raise DataFileError(f"{path}: {UFF_EXTRA}" if path is not None else UFF_EXTRA) from None
    return pyuff

_MODEL_TAG = "model:"
_ID_WIDTH = 80


def write_uff55(data: ModalData, path: str | Path) -> Path:
    """Write `data` as UFF dataset 55, one normal-mode dataset per mode; returns the path.

    Frequencies in Hz; shapes as given (sign and scale carry no meaning). Raises
    DataFileError naming the file if a mode has no shape, a DOF direction is not a spatial one,
    or the model name does not fit in ID line 1.
    """
    path = Path(path)
    missing = np.flatnonzero(~data.has_shape)
    if missing.size:
        listed = ", ".join(f"{k + 1} ({data.frequencies_hz[k]:.6g} Hz)" for k in missing)
        raise DataFileError(
            f"{path}: mode(s) {listed} have no measured shape, and UFF dataset 55 holds one shape per "
            "mode: write JSON instead, or only the modes with shapes "
            "(data.subset(np.flatnonzero(data.has_shape)))")
    if any(not isinstance(d, tuple) for d in data.dofs):
        raise DataFileError(f"{path}: the DOFs are row numbers of a model given as matrices; UFF dataset 55 "
                            "holds [node, direction] coordinates: write JSON instead")
    bad = [d for d in data.dofs if d[1] not in SPATIAL]
    if bad:
        raise DataFileError(f"{path}: DOF(s) {bad} have a direction other than {', '.join(SPATIAL)}")
    if data.model is None:
        raise DataFileError(f"{path}: the data name no model, and UFF dataset 55 names one on its ID line: write "
                            "JSON instead")
    id1 = f"{_MODEL_TAG} {data.model}"
    if len(id1) > _ID_WIDTH:
        raise DataFileError(f"{path}: the model name {data.model!r} is longer than the "
                            f"{_ID_WIDTH - len(_MODEL_TAG) - 1} characters UFF ID line 1 can hold")
    source = str(data.meta.get("source", "")).strip() or "NONE"

    nodes = list(dict.fromkeys(node for node, _ in data.dofs))  # order of first appearance
    row = {n: i for i, n in enumerate(nodes)}
    values = np.zeros((data.n_modes, len(nodes), 6))
    for i, (node, direction) in enumerate(data.dofs):
        values[:, row[node], SPATIAL.index(direction)] = data.shapes[i]

    pyuff = uff_library(path)  # imported where used: `import fe_problem` does not need it

    datasets = []
    for k in range(data.n_modes):
        v = values[k]
        datasets.append(pyuff.prepare_55(
            id1=id1, id2=source[:_ID_WIDTH], id3="NONE", id4=f"mode {k + 1}", id5="NONE",
            model_type=1, analysis_type=2, data_ch=3, spec_data_type=8, data_type=2, n_data_per_node=6,
            r1=v[:, 0], r2=v[:, 1], r3=v[:, 2], r4=v[:, 3], r5=v[:, 4], r6=v[:, 5],
            node_nums=np.array(nodes, dtype=int), load_case=1, mode_n=k + 1,
            freq=float(data.frequencies_hz[k]), modal_m=0.0, modal_damp_vis=0.0, modal_damp_his=0.0))
    try:
        pyuff.UFF(str(path)).write_sets(datasets, mode="overwrite")
    except Exception as exc:  # pyuff raises bare Exceptions
        raise DataFileError(f"{path}: cannot write UFF ({exc})") from None
    return path


#: Dataset types a UFF file of modes may carry besides 55 without anything being lost:
#: header (151), units (164), nodes and elements (15, 2411, 82, 2412), coordinate systems (18, 2420).
HEADER_DATASETS = frozenset({151, 164, 15, 2411, 82, 2412, 18, 2420})


#: The largest UFF file read (bytes): pyuff holds the whole text in memory several times over.
MAX_UFF_BYTES = 512 * 2**20


def uff_dataset_lines(path: Path, kind: int, error=DataFileError) -> list[int]:
    """The lines (1-based) where the datasets of type `kind` open in the UFF file `path`, checking
    its structure on the way: every dataset opens with a line '    -1', then a line with its type
    number, and closes with '    -1'. `error` (naming the file and the line) for a file that is
    no regular file or too large, a file cut short (a dataset with no closing delimiter, a last
    line cut in the middle) or a damaged type line. Datasets of other types among those of
    `kind` (any type but the header, units and geometry datasets before the first of `kind`)
    are named in a warning: one of them may be a damaged dataset of `kind`."""
    try:
        if not path.is_file():
            raise error(f"{path}: not a regular file (a directory, a device or a pipe); name a UFF file")
        if path.stat().st_size > MAX_UFF_BYTES:
            raise error(f"{path}: larger than the {MAX_UFF_BYTES} bytes a UFF file may have")
        text = path.read_bytes().decode("latin-1")
    except OSError as exc:
        raise error(f"{path}: cannot be read ({exc.strerror or exc})") from None
    lines = text.splitlines()
    opened_at, inside, opened, others = [], False, 0, {}
    for number, line in enumerate(lines, 1):
        if line.strip() != "-1":
            continue
        if inside:
            inside = False
            continue
        inside, opened = True, number
        head_line = lines[number] if number < len(lines) else ""
        head = head_line.split()
        if not head or not head[0].isdigit():
            raise error(f"{path}: line {number + 1}: the dataset opened at line {number} has no type number "
                        f"(found {head_line.strip()[:20]!r}): the file is damaged or cut short")
        t = int(head[0])
        if t == kind:
            opened_at.append(number)
        elif t not in HEADER_DATASETS or opened_at:
            others[t] = others.get(t, 0) + 1
    if inside:
        raise error(f"{path}: the dataset opened at line {opened} is never closed by '    -1': the file is cut "
                    "short or damaged")
    if others and opened_at:
        warnings.warn(f"{path}: ignored {sum(others.values())} dataset(s) of type(s) {sorted(others)} among the "
                      f"{len(opened_at)} datasets {kind}: if one was meant to be a dataset {kind}, the file is damaged",
                      stacklevel=3)
    return opened_at


def read_uff55(path: str | Path, model: str | None = None, layout: DofLayout | None = None) -> ModalData:
    """Read the normal modes of the datasets 55 in a UFF file (other dataset types are ignored).

    `model`: the model the data belongs to, if ID line 1 does not name it; `layout`: the DOFs
    its nodes have (values in other directions are refused; default: the layout of the model
    the data name, the planar frame's if that model cannot be read here). The result obeys
    the rules of the JSON format (docs/modal-data-format.md); every error is a
    DataFileError that names the file, the dataset and what is wrong.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no data file {str(path)!r}")
    if path.is_dir():
        raise DataFileError(f"{path}: is a directory, not a UFF file")
    opened_at = uff_dataset_lines(path, 55)
    n_raw = len(opened_at)
    pyuff = uff_library(path)

    try:
        uff = pyuff.UFF(str(path))
        types = [int(t) for t in uff.get_set_types()]
    except Exception as exc:
        raise DataFileError(f"{path}: not a readable UFF file ({exc})") from None
    if not types:
        raise DataFileError(f"{path}: not a UFF file (no '    -1' delimited dataset found)")
    blocks = [i for i, t in enumerate(types) if t == 55]
    if len(blocks) != n_raw:
        raise DataFileError(f"{path}: the file holds {n_raw} datasets 55 but only {len(blocks)} can be read: "
                            "it is damaged (cut short or edited)")
    if not blocks:
        raise DataFileError(f"{path}: no dataset 55 (data at nodes) in the file; it holds dataset type(s) "
                            f"{sorted(set(types))}")

    nodes, model_id, source = None, "", ""
    freqs, shapes = [], []
    for k, block in enumerate(blocks, 1):
        where = f"{path}: dataset 55 #{k} (line {opened_at[k - 1]})"
        try:
            ds = uff.read_sets(block)
        except Exception as exc:
            raise DataFileError(f"{where}: cannot be read ({exc})") from None
        if k == 1:
            model_id, source = str(ds.get("id1", "")).strip(), str(ds.get("id2", "")).strip()
            if model is None:
                model = model_id[len(_MODEL_TAG):].strip() if model_id.lower().startswith(_MODEL_TAG) else model_id
            if layout is None:
                layout = _layout_of(model, path)
        node_nums, v, f = _normal_mode(ds, where, layout)
        if nodes is None:
            nodes = node_nums
        elif node_nums != nodes:
            raise DataFileError(f"{where}: inconsistent nodes across modes: dataset #1 lists nodes {nodes}, "
                                f"this one {node_nums}")
        freqs.append(f)
        shapes.append(v)

    dofs, rows = _measured(nodes, np.stack(shapes), layout)
    if not model or model.upper() == "NONE":
        raise DataFileError(f"{path}: ID line 1 of dataset 55 #1 does not name the model the data belongs to "
                            f"(write '{_MODEL_TAG} <shipped model name or model file path>' there)")
    meta = {} if source.upper() in ("", "NONE") else {"source": source}
    raw = {"format": DATA_FORMAT, "model": model, "dofs": [list(d) for d in dofs],
           "modes": [{"frequency_hz": f, "shape": rows[m].tolist()} for m, f in enumerate(freqs)], "meta": meta}
    return modal_data_from_dict(raw, source=str(path))


def _layout_of(model: str, path: Path) -> DofLayout:
    """The DOF layout of the model a UFF file names (the planar frame's if it cannot be read:
    the file is then read as before, and the model's own error comes when it is loaded)."""
    if not model or model.upper() == "NONE":
        return DEFAULT_LAYOUT
    try:
        return model_named(model, str(path)).layout
    except (OSError, ValueError):
        return DEFAULT_LAYOUT


def _measured(nodes: list[int], values: np.ndarray, layout: DofLayout) -> tuple[list, np.ndarray]:
    """The measured DOFs [(node, direction), ...] (those non-zero in some mode, in file order)
    and their values (mode, dof), from values (mode, node, 6) of the datasets 55."""
    measured = np.any(values != 0.0, axis=0)  # (node, 6)
    entries = [(i, d) for i in range(len(nodes)) for d in layout.names if measured[i, layout.spatial_column(d)]]
    rows = values[:, [i for i, _ in entries], [layout.spatial_column(d) for _, d in entries]]
    return [(nodes[i], d) for i, d in entries], rows


def _normal_mode(ds: dict, where: str, layout: DofLayout) -> tuple[list[int], np.ndarray, float]:
    """Node numbers, values (n_node, 6: x, y, z, rx, ry, rz) and frequency (Hz) of one
    dataset 55, checked to be a real normal mode with values only in `layout`'s DOFs."""
    if ds.get("analysis_type") != 2:
        raise DataFileError(f"{where}: analysis type {ds.get('analysis_type')} is not 2 (normal mode); "
                            "only real normal modes are read")
    if ds.get("data_type") != 2:
        raise DataFileError(f"{where}: data type {ds.get('data_type')} is not 2 (real); "
                            "complex shapes are not read")
    if ds.get("data_ch") not in (2, 3):
        raise DataFileError(f"{where}: data characteristic {ds.get('data_ch')} is not 2 (3 translations) "
                            "or 3 (3 translations and 3 rotations): the directions are unknown")
    node_nums = [int(n) for n in ds["node_nums"]]
    if len(set(node_nums)) != len(node_nums):
        raise DataFileError(f"{where}: a node is listed twice in {node_nums}")
    n_values = 6 if ds["data_ch"] == 3 else 3
    v = np.column_stack([ds[f"r{c}"] for c in range(1, n_values + 1)])
    if not np.all(np.isfinite(v)):
        raise DataFileError(f"{where}: a shape value is not a finite number")
    for col, name in enumerate(SPATIAL[:n_values]):
        if name not in layout.names and np.any(v[:, col] != 0.0):
            node = node_nums[int(np.flatnonzero(v[:, col])[0])]
            raise DataFileError(f"{where}: node {node} has a non-zero {name} value; the model's nodes have only "
                                f"{', '.join(layout.names)}")
    if not np.any(v):
        raise DataFileError(f"{where} (mode {ds.get('mode_n')}): every value is zero; a dataset 55 must hold "
                            "the mode's shape")
    f = float(ds["freq"])
    if not (np.isfinite(f) and f > 0):
        raise DataFileError(f"{where}: frequency {f} Hz must be a finite number > 0")
    if n_values == 3:
        v = np.column_stack([v, np.zeros((v.shape[0], 3))])
    return node_nums, v, f
