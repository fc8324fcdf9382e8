"""Frequency response functions on disk: UFF dataset 58 (through pyuff), `.npz` and CSV.

One `FRFSet` holds what a single-reference modal test gave: FRFs (n_channels, n_lines)
complex, on one uniform frequency axis (Hz), one measured coordinate per channel, the one
fixed coordinate they share (the reference), the FRF form and its units.

Roving hammer or shaker: in UFF 58 a channel is (response, reference). A shaker test (or a
roving accelerometer) has one reference and many responses; a roving-hammer test has one
response (the fixed accelerometer) and many references. By reciprocity both measure one
column of the FRF matrix: the measured coordinates are the coordinates that change, the
fixed one is `reference`. Several files are merged (same axis, form, units and reference).

Layouts (docs/identify.md has examples):
- UFF 58: function type 4 (FRF), complex ordinate; directions 1..6 (x, y, z, rx, ry, rz; a
  planar model's nodes have 1, 2 and 6, checked against the model), a negative direction flips the sign; ordinate type 12 / 11 / 8 (acceleration, velocity, displacement)
  over 13 (force) gives accelerance / mobility / receptance. ID line 1 may name the model:
  ``model: hframe``.
- `.npz`: ``frequency_hz`` (n_lines,), ``frf`` (n_channels, n_lines) complex,
  ``response_node`` (n,) int, ``response_dir`` (n,) str, ``reference_node`` int,
  ``reference_dir`` str, ``form`` str, ``units`` str, optional ``model`` str.
- CSV: comment lines ``# model: hframe``, ``# form: accelerance``, ``# units: m/s^2/N``,
  ``# reference: 5 x``; a header ``frequency_hz,re 1 x,im 1 x,re 2 x,im 2 x,...``; one row per line.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..dofs import SPATIAL
from ..jsonutil import check_keys
from ..safe_files import open_for_writing, refuse_link
from .csv_numbers import number_table
from .units import SI_UNITS, abscissa_factor, ordinate_factor

#: UFF direction codes (1..6 for x, y, z, rx, ry, rz) of nodal DOFs, and back; which of them a
#: model's nodes have is its layout's (checked by `identification.core.check_coordinates`)
UFF_DIRECTION = {name: SPATIAL.index(name) + 1 for name in SPATIAL}
_DIRECTION_OF = {v: k for k, v in UFF_DIRECTION.items()}
_CODES_TEXT = ", ".join(f"{c} {n}" for n, c in UFF_DIRECTION.items())
_NAMES_TEXT = ", ".join(UFF_DIRECTION)
#: FRF form by UFF ordinate specific data type (over force, type 13)
FORM_OF_ORDINATE = {12: "accelerance", 11: "mobility", 8: "receptance"}
ORDINATE_OF_FORM = {v: k for k, v in FORM_OF_ORDINATE.items()}
DEFAULT_UNITS = SI_UNITS
#: The arrays of the `.npz` layout: required, then optional
NPZ_REQUIRED = ("frequency_hz", "frf", "response_node", "response_dir", "reference_node", "reference_dir")
NPZ_OPTIONAL = ("form", "units", "model")
#: The largest decompressed size of an `.npz` file's arrays (bytes), read from the arrays' own
#: headers before any is loaded: 1000 channels of 100,000 complex lines are 1.6 GB
MAX_NPZ_BYTES = 2 * 2**30
#: The largest CSV or UFF file read (bytes): a UFF 58 text file of 1000 channels of 100,000 lines
#: is about 5 GB; larger tests are split into several files
MAX_TEXT_FRF_BYTES = 8 * 2**30
_MODEL_TAG = "model:"


class FRFFileError(ValueError):
    """An FRF file that cannot be used; the message names the file and the channel."""


@dataclass(frozen=True, eq=False)
class FRFSet:
    """Single-reference FRFs: frequency_hz (n_lines,) uniform, frf (n_channels, n_lines) complex
    in `units` (SI, e.g. m/s^2/N), coordinates: one (node, direction) per channel, reference:
    the fixed (node, direction), form: accelerance, mobility or receptance."""

    frequency_hz: np.ndarray
    frf: np.ndarray
    coordinates: tuple[tuple[int, str], ...]
    reference: tuple[int, str]
    form: str = "accelerance"
    units: str = "m/s^2/N"
    model: str | None = None
    sources: tuple[str, ...] = ("<memory>",)
    channel_sources: tuple[tuple[str, int], ...] = field(default=())  # (file, 1-based channel in it)

    @property
    def n_channels(self) -> int:
        return int(self.frf.shape[0])

    def channel_label(self, k: int) -> str:
        """'FILE: channel k (node dir)' for error messages (k 0-based, shown 1-based)."""
        src, index = self.channel_sources[k] if self.channel_sources else (self.sources[0], k + 1)
        node, d = self.coordinates[k]
        return f"{src}: channel {index} ({node} {d})"


# == UFF 58 ===================================================================================
def write_uff58(frfs: FRFSet, path: str | Path, test: str = "roving-hammer") -> Path:
    """Write every channel as a UFF dataset 58 (FRF, complex, even abscissa); returns the path.

    test "roving-hammer": response = the fixed coordinate, reference = the channel's (the
    hammer moves); "shaker": reference = the fixed coordinate, response = the channel's."""
    if test not in ("roving-hammer", "shaker"):
        raise ValueError(f"test must be 'roving-hammer' or 'shaker', got {test!r}")
    from ..modal_data.uff import uff_library

    pyuff = uff_library(path)

    path = refuse_link(path)
    ordinate = ORDINATE_OF_FORM[frfs.form]
    id1 = f"{_MODEL_TAG} {frfs.model}" if frfs.model else "NONE"
    if len(id1) > 80:
        raise FRFFileError(f"{path}: the model name {frfs.model!r} is longer than UFF ID line 1 can hold "
                           f"({80 - len(_MODEL_TAG) - 1} characters): name the model with --model when identifying")
    ref_node, ref_dir = frfs.reference
    f = np.asarray(frfs.frequency_hz, float)
    sets = []
    for k, (node, d) in enumerate(frfs.coordinates):
        rsp, ref = ((ref_node, ref_dir), (node, d)) if test == "roving-hammer" else ((node, d), (ref_node, ref_dir))
        sets.append(pyuff.prepare_58(
            binary=0, id1=id1, id2="femu synthetic test rig" if frfs.sources == ("<memory>",) else "NONE",
            id3="NONE", id4=f"channel {k + 1}", id5="NONE", func_type=4, ver_num=0, load_case_id=0,
            rsp_ent_name="frame", rsp_node=int(rsp[0]), rsp_dir=UFF_DIRECTION[rsp[1]], ref_ent_name="frame",
            ref_node=int(ref[0]), ref_dir=UFF_DIRECTION[ref[1]], abscissa_spacing=1,
            abscissa_spec_data_type=18, abscissa_axis_units_lab="Hz", ordinate_spec_data_type=ordinate,
            ordinate_axis_units_lab=frfs.units, orddenom_spec_data_type=13, orddenom_axis_units_lab="N",
            data=np.asarray(frfs.frf[k], complex), x=f))
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    return path


def _uff_channel(ds: dict, where: str):
    """(response, reference, form, units, x, data) of one dataset 58, checked."""
    if int(ds.get("func_type", 0)) != 4:
        raise FRFFileError(f"{where}: function type {ds.get('func_type')} is not 4 (frequency response function)")
    coords = []
    for role in ("rsp", "ref"):
        node, code = int(ds.get(f"{role}_node", 0)), int(ds.get(f"{role}_dir", 0))
        name = "response" if role == "rsp" else "reference"
        if node <= 0 or code == 0:
            raise FRFFileError(f"{where}: missing {name} coordinate (node {node}, direction {code})")
        if abs(code) not in _DIRECTION_OF:
            raise FRFFileError(f"{where}: {name} direction {code} is not a nodal DOF (use {_CODES_TEXT})")
        coords.append((node, _DIRECTION_OF[abs(code)], -1.0 if code < 0 else 1.0))
    ordinate = int(ds.get("ordinate_spec_data_type", 12))
    if ordinate not in FORM_OF_ORDINATE or int(ds.get("orddenom_spec_data_type", 13)) != 13:
        raise FRFFileError(f"{where}: ordinate type {ordinate} over {ds.get('orddenom_spec_data_type')} is not "
                           "acceleration (12), velocity (11) or displacement (8) over force (13)")
    form = FORM_OF_ORDINATE[ordinate]
    scale = ordinate_factor(ds.get("ordinate_axis_units_lab", ""), form, where, FRFFileError)
    to_hz = abscissa_factor(ds.get("abscissa_axis_units_lab", ""), where, FRFFileError,
                            uff_type=int(ds.get("abscissa_spec_data_type", 18)))
    data = np.asarray(ds["data"])
    if not np.iscomplexobj(data):
        raise FRFFileError(f"{where}: real ordinate data; an FRF needs complex values")
    sign = coords[0][2] * coords[1][2]
    return (coords[0][:2], coords[1][:2], form, DEFAULT_UNITS[form], to_hz * np.asarray(ds["x"], float),
            (sign * scale) * data)


def uff_datasets(path: str | Path, dataset_type: int, what: str, error=FRFFileError):
    """Yield (k, ds) for the k-th (1-based) dataset of `dataset_type` in a UFF file, read by pyuff.

    `what` describes the type in messages; every failure is `error` naming the file (and the
    dataset). One reader for any UFF dataset type (uff.py's dataset 55 reader could use it too)."""
    from ..modal_data.uff import uff_dataset_lines, uff_library

    pyuff = uff_library(path)

    path = Path(path)
    opened_at = uff_dataset_lines(path, dataset_type, error)  # a file cut short or damaged: refused here
    try:
        uff = pyuff.UFF(str(path))
        types = [int(t) for t in uff.get_set_types()]
    except Exception as exc:  # pyuff raises bare Exceptions
        raise error(f"{path}: not a readable UFF file ({exc})") from None
    blocks = [i for i, t in enumerate(types) if t == dataset_type]
    if not blocks:
        if dataset_type == 58 and 55 in types:
            raise error(f"{path}: a UFF file of modal data (dataset 55: measured modes), not FRFs; `femu identify` "
                        f"reads {_FRF_FORMATS} and finds the modes; to diagnose these modes: femu diagnose {path}")
        raise error(f"{path}: no dataset {dataset_type} ({what}) in the file; it holds dataset type(s) "
                    f"{sorted(set(types))}")
    if len(blocks) != len(opened_at):
        raise error(f"{path}: the file holds {len(opened_at)} datasets {dataset_type} but only {len(blocks)} can be "
                    "read: it is damaged (cut short or edited)")
    for k, block in enumerate(blocks, 1):
        try:
            yield k, uff.read_sets(block)
        except Exception as exc:
            raise error(f"{path}: dataset {dataset_type} #{k} (line {opened_at[k - 1]}): cannot be read "
                        f"({str(exc).strip() or type(exc).__name__}; a value that is no number?)") from None


def read_uff58(path: str | Path) -> FRFSet:
    """The FRFs (datasets 58) of one UFF file; other dataset types are ignored."""
    channels, model = [], None
    for k, ds in uff_datasets(path, 58, "function at nodal DOF"):
        where = f"{path}: channel {k} (dataset 58 #{k})"
        channels.append((where,) + _uff_channel(ds, where))
        id1 = str(ds.get("id1", "")).strip()
        if k == 1 and id1.lower().startswith(_MODEL_TAG):
            model = id1[len(_MODEL_TAG):].strip() or None
    return _assemble(channels, str(path), model)


def _assemble(channels: list, source: str, model: str | None) -> FRFSet:
    """One FRFSet from checked channels (where, response, reference, form, units, x, data)."""
    where0, rsp0, ref0, form0, units0, x0, _ = channels[0]
    for where, rsp, ref, form, units, x, data in channels[1:]:
        if (form, units) != (form0, units0):
            raise FRFFileError(f"{where}: mixed units: {form} in {units}, but {where0} is {form0} in {units0}")
        if x.shape != x0.shape or not np.allclose(x, x0, rtol=1e-9, atol=1e-9):
            raise FRFFileError(f"{where}: frequency lines differ from those of {where0}")
    refs = {c[2] for c in channels}
    rsps = {c[1] for c in channels}
    if len(refs) == 1 and (len(rsps) > 1 or len(channels) == 1):
        reference, coords = ref0, [c[1] for c in channels]        # shaker / roving accelerometer
    elif len(rsps) == 1:
        reference, coords = rsp0, [c[2] for c in channels]        # roving hammer
    else:
        raise FRFFileError(f"{source}: no common reference: channels have {len(refs)} different references and "
                           f"{len(rsps)} different responses; one coordinate must be fixed in every channel")
    data = np.stack([c[6] for c in channels])
    return _checked(FRFSet(x0, data, tuple(coords), reference, form0, units0, model, (source,),
                           tuple((source, k) for k in range(1, len(channels) + 1))))


def _checked(frfs: FRFSet) -> FRFSet:
    """Uniform ascending axis, finite values, no coordinate twice; errors name file and channel."""
    f = frfs.frequency_hz
    src = frfs.sources[0]
    if f.ndim != 1 or f.size < 3:
        raise FRFFileError(f"{src}: needs at least 3 frequency lines, got {f.size}")
    if not np.all(np.isfinite(f)):
        raise FRFFileError(f"{src}: a frequency line is not a finite number")
    if f[0] < 0:
        raise FRFFileError(f"{src}: the frequency lines start at {f[0]:g} Hz, below 0 Hz: the abscissa is not "
                           "a frequency axis in Hz (a shifted or two-sided axis?)")
    df = np.diff(f)
    if not (np.all(df > 0) and np.allclose(df, df[0], rtol=1e-6, atol=0)):
        raise FRFFileError(f"{src}: the frequency lines must be evenly spaced and ascending")
    if frfs.frf.shape != (len(frfs.coordinates), f.size):
        raise FRFFileError(f"{src}: FRF array of shape {frfs.frf.shape}, expected "
                           f"({len(frfs.coordinates)}, {f.size}) (channels, lines)")
    seen = {}
    for k, c in enumerate(frfs.coordinates):
        if not np.all(np.isfinite(frfs.frf[k])):
            raise FRFFileError(f"{frfs.channel_label(k)}: a value is not a finite number")
        if not np.any(frfs.frf[k]):
            raise FRFFileError(f"{frfs.channel_label(k)}: every value is zero: the channel measured nothing "
                               "(a disconnected sensor?); leave it out of the file")
        if c in seen:
            raise FRFFileError(f"{frfs.channel_label(k)}: the coordinate is measured twice "
                               f"(also channel {seen[c] + 1})")
        seen[c] = k
    return frfs


# == .npz and CSV =============================================================================
def write_npz(frfs: FRFSet, path: str | Path) -> Path:
    """Write the `.npz` layout of the module docstring; returns the path."""
    path = refuse_link(path)
    np.savez(path, frequency_hz=frfs.frequency_hz, frf=frfs.frf,
             response_node=np.array([c[0] for c in frfs.coordinates]),
             response_dir=np.array([c[1] for c in frfs.coordinates]), reference_node=frfs.reference[0],
             reference_dir=frfs.reference[1], form=frfs.form, units=frfs.units, model=frfs.model or "")
    return path


def _npz_sizes(path: Path) -> None:
    """Refuse an `.npz` whose arrays, as their own headers declare them, are larger than
    MAX_NPZ_BYTES, before any is decompressed (a small zip can expand to many gigabytes)."""
    import zipfile

    try:
        with zipfile.ZipFile(path) as zf:
            total = 0
            for info in zf.infolist():
                with zf.open(info) as fh:
                    fmt = np.lib.format
                    read_header = {(1, 0): fmt.read_array_header_1_0,
                                   (2, 0): fmt.read_array_header_2_0}[fmt.read_magic(fh)]
                    shape, _, dtype = read_header(fh)
                total += int(np.prod(shape, dtype=object)) * dtype.itemsize
                if total > MAX_NPZ_BYTES:
                    raise FRFFileError(f"{path}: its arrays would take more than {MAX_NPZ_BYTES} bytes when "
                                       f"decompressed (array {info.filename!r}: shape {shape} of {dtype}); "
                                       "split the test into several files")
    except FRFFileError:
        raise
    except Exception:
        raise FRFFileError(f"{path}: not a readable .npz file (a zip archive of numpy arrays without objects, "
                           "as numpy.savez writes)") from None


def read_npz(path: str | Path) -> FRFSet:
    """The FRFs of an `.npz` file in the layout of the module docstring."""
    path = Path(path)
    _npz_sizes(path)
    try:
        z = np.load(path, allow_pickle=False)
    except Exception:
        raise FRFFileError(f"{path}: not a readable .npz file (a zip archive of numpy arrays without objects, "
                           "as numpy.savez writes)") from None
    if not isinstance(z, np.lib.npyio.NpzFile):
        raise FRFFileError(f"{path}: a single .npy array, not an .npz archive of named arrays")
    try:
        with z:
            return _checked(_npz_set(z, path))
    except (ValueError, TypeError, OverflowError) as exc:  # a field of the wrong type: an object array, text as node
        if isinstance(exc, FRFFileError):
            raise
        raise FRFFileError(f"{path}: an array of the wrong type or shape ({exc}); see docs/identify.md") from None


def _npz_array(z, path: Path, key: str, kinds: str, ndim: int, what: str) -> np.ndarray:
    """Array `key` checked for its dtype kind (numpy's kind letters) and number of dimensions
    (0 also admits a one-element array); FRFFileError naming the file, the array and the problem."""
    a = z[key]
    if a.dtype.kind not in kinds or (a.ndim != ndim and not (ndim == 0 and a.size == 1)):
        shape = "a single value" if ndim == 0 else f"a {ndim}-D array"
        raise FRFFileError(f"{path}: array {key!r} must be {shape} of {what}; it is {a.dtype} of shape {a.shape}")
    return a.reshape(()) if ndim == 0 else a


def _npz_set(z, path: Path) -> FRFSet:
    """The FRFSet of the arrays of an open .npz file (not yet checked)."""
    missing = [k for k in NPZ_REQUIRED if k not in z.files]
    if missing:
        raise FRFFileError(f"{path}: missing array(s) {missing} (see docs/identify.md)")
    check_keys(z.files, NPZ_REQUIRED + NPZ_OPTIONAL, f"{path}: array names", FRFFileError)
    text = {k: str(_npz_array(z, path, k, "U", 0, "text")) for k in ("reference_dir",) + NPZ_OPTIONAL
            if k in z.files}
    form = text.get("form", "accelerance")
    if form not in DEFAULT_UNITS:
        raise FRFFileError(f"{path}: field 'form' {form!r} is not accelerance, mobility or receptance")
    f = _npz_array(z, path, "frequency_hz", "iuf", 1, "real numbers (Hz)")
    if z["frf"].dtype.kind in "iuf":
        raise FRFFileError(f"{path}: array 'frf' holds real values; an FRF needs complex values")
    frf = _npz_array(z, path, "frf", "c", 2, "complex numbers (channels x lines)")
    nodes = _npz_array(z, path, "response_node", "iu", 1, "whole numbers (node ids)")
    dirs = [str(d) for d in _npz_array(z, path, "response_dir", "U", 1, "text (directions)")]
    ref_node = _npz_array(z, path, "reference_node", "iu", 0, "a whole number (node id)")
    if len(nodes) != len(dirs):
        raise FRFFileError(f"{path}: {len(nodes)} response nodes but {len(dirs)} response directions")
    for k, d in enumerate(dirs):
        if d not in UFF_DIRECTION:
            raise FRFFileError(f"{path}: channel {k + 1}: direction {d!r} is not one of {_NAMES_TEXT}")
    if text["reference_dir"] not in UFF_DIRECTION:
        raise FRFFileError(f"{path}: array 'reference_dir': direction {text['reference_dir']!r} is not one of "
                           f"{_NAMES_TEXT}")
    scale = ordinate_factor(text.get("units", ""), form, f"{path}: field 'units'", FRFFileError)
    return FRFSet(np.asarray(f, float), scale * np.asarray(frf, complex),
                  tuple((int(n), d) for n, d in zip(nodes, dirs)), (int(ref_node), text["reference_dir"]), form,
                  DEFAULT_UNITS[form], text.get("model") or None, (str(path),))


def write_csv(frfs: FRFSet, path: str | Path) -> Path:
    """Write the CSV layout of the module docstring; returns the path."""
    path = Path(path)
    head = [f"# model: {frfs.model or 'NONE'}", f"# form: {frfs.form}", f"# units: {frfs.units}",
            f"# reference: {frfs.reference[0]} {frfs.reference[1]}"]
    cols = ["frequency_hz"] + [f"{p} {n} {d}" for n, d in frfs.coordinates for p in ("re", "im")]
    table = np.empty((frfs.frequency_hz.size, 1 + 2 * frfs.n_channels))
    table[:, 0] = frfs.frequency_hz
    table[:, 1::2], table[:, 2::2] = frfs.frf.real.T, frfs.frf.imag.T
    with open_for_writing(path, newline="") as fh:
        fh.write("\n".join(head) + "\n" + ",".join(cols) + "\n")
        np.savetxt(fh, table, delimiter=",", fmt="%.10g")
    return path


#: The keys of a CSV file's metadata comment lines (``# key: value``)
CSV_KEYS = ("model", "form", "units", "reference")


def read_csv(path: str | Path) -> FRFSet:
    """The FRFs of a CSV file in the layout of the module docstring.

    The one rule for lines: a line whose first non-blank character is ``#`` is a comment wherever
    it stands, and a blank line is skipped; a comment ``# key: value`` with a key of `CSV_KEYS`
    is metadata (each key once; a key close to one of them, such as ``# refrence:``, is refused
    as a misspelling), any other comment is free text. The first other line is the header; every
    line after it is one frequency line with exactly the header's number of fields."""
    path = Path(path)
    _bounded_size(path)
    try:
        lines = path.read_bytes().decode("utf-8-sig").splitlines()
    except UnicodeDecodeError as exc:
        raise FRFFileError(f"{path}: not UTF-8 text (byte at offset {exc.start}); save the file as UTF-8") from None
    meta, rows = {}, []
    for number, line in enumerate(lines, 1):
        text = line.strip()
        if text.startswith("#"):
            key, colon, value = text[1:].partition(":")
            key = key.strip().lower()
            if colon and key in CSV_KEYS:
                if key in meta:
                    raise FRFFileError(f"{path}: line {number}: '# {key}:' is given twice")
                meta[key] = value.strip()
            elif colon and " " not in key:
                import difflib
                close = difflib.get_close_matches(key, CSV_KEYS, n=1, cutoff=0.75)
                if close:
                    raise FRFFileError(f"{path}: line {number}: unknown key '# {key}:'; did you mean '# {close[0]}:'?")
        elif text:
            rows.append((number, text))
    if not rows or not rows[0][1].startswith("frequency_hz"):
        raise FRFFileError(f"{path}: no header line starting with 'frequency_hz'")
    cols = [c.strip() for c in next(csv.reader([rows[0][1]]))[1:]]
    if len(cols) % 2 or "reference" not in meta:
        raise FRFFileError(f"{path}: {'missing reference (a line # reference: NODE DIR)' if 'reference' not in meta else 'columns must come in re/im pairs'}")
    coords = []
    for k in range(0, len(cols), 2):
        parts, parts_im = cols[k].split(), cols[k + 1].split()
        if len(parts) != 3 or parts[0] != "re" or parts_im != ["im"] + parts[1:] or parts[2] not in UFF_DIRECTION:
            raise FRFFileError(f"{path}: channel {k // 2 + 1}: columns {cols[k]!r}, {cols[k + 1]!r} are not "
                               f"'re NODE DIR', 'im NODE DIR' with DIR one of {_NAMES_TEXT}")
        if not parts[1].isdigit():
            raise FRFFileError(f"{path}: channel {k // 2 + 1}: column {cols[k]!r}: node {parts[1]!r} is not a node id")
        coords.append((int(parts[1]), parts[2]))
    ref = meta["reference"].split()
    form = meta.get("form", "accelerance")
    if len(ref) != 2 or not ref[0].isdigit() or ref[1] not in UFF_DIRECTION or form not in DEFAULT_UNITS:
        raise FRFFileError(f"{path}: bad '# reference: {meta['reference']}' or '# form: {form}'")
    if len(rows) < 2:
        raise FRFFileError(f"{path}: no frequency lines after the header")
    table = number_table(rows[1:], ["frequency_hz", *cols], str(path), FRFFileError,
                         " (frequency_hz and a re/im pair per channel)")
    scale = ordinate_factor(meta.get("units", ""), form, f"{path}: '# units:'", FRFFileError)
    model = meta.get("model")
    return _checked(FRFSet(table[:, 0], scale * (table[:, 1::2] + 1j * table[:, 2::2]).T, tuple(coords),
                           (int(ref[0]), ref[1]), form, DEFAULT_UNITS[form],
                           None if model in (None, "", "NONE") else model, (str(path),)))


def _bounded_size(path: Path) -> None:
    """Refuse a text FRF file larger than MAX_TEXT_FRF_BYTES before reading it."""
    size = path.stat().st_size
    if size > MAX_TEXT_FRF_BYTES:
        raise FRFFileError(f"{path}: {size} bytes, more than the {MAX_TEXT_FRF_BYTES} an FRF file may have; "
                           "split the test into several files")


# == one entry point ==========================================================================
def read_frf(*paths: str | Path) -> FRFSet:
    """Read and merge FRF files (UFF 58 `.uff`/`.unv`, `.npz`, `.csv`) into one FRFSet.

    Every file must share the frequency axis, the form and units, and the reference; a
    coordinate may appear once. Errors are FRFFileError/FileNotFoundError naming file and channel."""
    if not paths:
        raise ValueError("no FRF file given")
    sets = []
    for p in paths:
        p = Path(p)
        if not p.exists():
            raise FileNotFoundError(f"no FRF file {str(p)!r}")
        if not p.is_file():
            raise FRFFileError(f"{p}: not a regular file (a directory, a device or a pipe); name an FRF file")
        suffix = p.suffix.lower()
        if suffix != ".npz":
            _bounded_size(p)
        if suffix not in (".npz", ".csv"):
            _json_holds_no_frfs(p)
        reader = {".npz": read_npz, ".csv": read_csv}.get(suffix, read_uff58)
        sets.append(reader(p))
    return merge(sets)


_FRF_FORMATS = "FRFs: UFF dataset 58 (.uff/.unv), .npz or .csv (docs/identify.md)"


def _json_holds_no_frfs(p: Path) -> None:
    """FRFFileError for a JSON file, which holds no FRFs: a modal-data file (what `femu diagnose`
    reads) is named as such, with what to do, not as a file that lacks a dataset 58 (a UFF file of
    modes, dataset 55, is named so by uff_datasets)."""
    with open(p, "rb") as f:
        head = f.read(4096).lstrip()
    if head[:1] in (b"{", b"["):
        import json

        try:
            doc = json.loads(p.read_text(encoding="utf-8"))
        except (ValueError, RecursionError):  # not JSON after all, or nested too deep
            doc = None
        fmt = doc.get("format") if isinstance(doc, dict) else None
        if isinstance(fmt, str) and fmt.startswith("femu.modal-data/"):
            raise FRFFileError(f"{p}: a modal-data file ({fmt}: measured modes), not FRFs; `femu identify` reads "
                               f"{_FRF_FORMATS} and finds the modes; to diagnose these modes: femu diagnose {p}")
        raise FRFFileError(f"{p}: a JSON file, not FRFs; `femu identify` reads {_FRF_FORMATS}")


def merge(sets: list[FRFSet]) -> FRFSet:
    """One FRFSet from several (same axis, form, units, reference, model)."""
    first = sets[0]
    for s in sets[1:]:
        where = s.channel_label(0)
        if (s.form, s.units) != (first.form, first.units):
            raise FRFFileError(f"{where}: mixed units: {s.form} in {s.units}, but {first.sources[0]} is "
                               f"{first.form} in {first.units}")
        if s.frequency_hz.shape != first.frequency_hz.shape or not np.allclose(s.frequency_hz, first.frequency_hz):
            raise FRFFileError(f"{where}: frequency lines differ from those of {first.sources[0]}")
        if s.reference != first.reference:
            raise FRFFileError(f"{where}: reference {s.reference} differs from {first.reference} in "
                               f"{first.sources[0]}; identification needs one reference")
        if s.model and first.model and s.model != first.model:
            raise FRFFileError(f"{where}: model {s.model!r} differs from {first.model!r} in {first.sources[0]}")
    if len(sets) == 1:
        return first
    channel_sources = tuple(s.channel_sources[k] if s.channel_sources else (s.sources[0], k + 1)
                            for s in sets for k in range(s.n_channels))
    return _checked(replace(first, frf=np.concatenate([s.frf for s in sets]),
                            coordinates=sum((s.coordinates for s in sets), ()),
                            model=next((s.model for s in sets if s.model), None),
                            sources=sum((s.sources for s in sets), ()), channel_sources=channel_sources))
