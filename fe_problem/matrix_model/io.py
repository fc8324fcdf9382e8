"""The matrix-model manifest (`femu.matrix-model/1`, docs/matrix-model.md): reading it with
every rule checked, and writing it back.

Matrix files: Matrix Market (.mtx, scipy.io.mmread), MATLAB (.mat, scipy.io.loadmat, `variable`
required), numpy (.npz: scipy.sparse.save_npz's archive, or arrays saved by numpy.savez with
`variable` naming one where there are several) and Nastran OUTPUT4 (.op4, pyNastran's reader,
`variable` required; the 'import' extra). Every failure is one MatrixModelError naming the
manifest, the term and the problem.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse as sp

from ..dofs import SPATIAL
from ..jsonutil import check_keys, dumps, read_json_file
from ..limits import MAX_SPARSE_DOFS
from ..model.validate import is_number, shown
from ..safe_files import write_text
from .types import FAMILIES, MATRIX_FORMAT, MatrixModel, MatrixModelError, MatrixTerm

#: The keys of a manifest and of a term (shared/formats/matrix-model.md); any other is refused.
MANIFEST_KEYS = ("format", "name", "dofs", "stiffness", "mass", "meta", "description")
TERM_KEYS = ("name", "file", "variable", "initial", "lower", "upper")
#: The matrix file types, by suffix.
SUFFIXES = (".mtx", ".mat", ".npz", ".op4")
#: A matrix whose largest |A - A^T| exceeds this fraction of its largest |A| is not symmetric.
SYMMETRY_TOL = 1e-10
#: K and M must be positive semi-definite at the initial values: their lowest eigenvalue not
#: below -PSD_TOL times their largest diagonal entry (checked by a Cholesky factorisation of
#: the matrix shifted by that much: it succeeds iff no eigenvalue is below the shift).
PSD_TOL = 1e-9
#: The most DOFs a matrix model may have: the sparse path's limit (fe_problem.limits).
MAX_DOFS = MAX_SPARSE_DOFS


def _fail(source, msg: str) -> MatrixModelError:
    return MatrixModelError(f"{source}: {msg}")


def load_matrix_model(path: str | Path) -> MatrixModel:
    """Read a matrix-model manifest and its matrix files (MatrixModelError naming the manifest,
    the term and the problem for any broken rule; FileNotFoundError for a missing manifest)."""
    if isinstance(path, MatrixModel):
        return path
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no matrix-model manifest {str(path)!r}")
    return matrix_model_from_dict(read_json_file(path, MatrixModelError), source=str(path))


def matrix_model_from_dict(d, source: str = "<memory>") -> MatrixModel:
    """Validate a parsed manifest and read its matrices (files relative to `source`'s folder)."""
    if not isinstance(d, dict):
        raise _fail(source, "the manifest must hold a JSON object")
    check_keys(d, MANIFEST_KEYS, source, MatrixModelError)
    for key in ("format", "dofs", "stiffness", "mass"):
        if key not in d:
            raise _fail(source, f"missing field '{key}'")
    if d["format"] != MATRIX_FORMAT:
        raise _fail(source, f"field 'format' must be {MATRIX_FORMAT!r}, got {shown(d['format'])}")
    name = d.get("name", Path(source).stem if source != "<memory>" else "matrix-model")
    if not isinstance(name, str) or not name.strip():
        raise _fail(source, f"field 'name' must be a non-empty string, got {shown(name)}")
    description = d.get("description", "")
    if not isinstance(description, str):
        raise _fail(source, "field 'description' must be a string")
    meta = d.get("meta", {})
    if not isinstance(meta, dict):
        raise _fail(source, "field 'meta' must be an object")
    dofs = _dofs(d["dofs"], source)
    base = Path(source).parent if source != "<memory>" else Path(".")
    seen: set[str] = set()
    families = {}
    for family in FAMILIES:
        entries = d[family]
        if not isinstance(entries, list) or not entries:
            raise _fail(source, f"field '{family}' must be a non-empty list of terms")
        terms = []
        for k, entry in enumerate(entries):
            term = _term(entry, family, k, base, len(dofs), source, seen)
            terms.append(term)
        families[family] = tuple(terms)
    model = MatrixModel(name, dofs, families["stiffness"], families["mass"], meta, source, description)
    check_definite(model)
    return model


def _dofs(value, source) -> tuple:
    """The DOF labels: 1..n for a count, else (node, direction) pairs, unique."""
    if isinstance(value, int) and not isinstance(value, bool):
        if not 1 <= value <= MAX_DOFS:
            raise _fail(source, f"field 'dofs': a count must be in [1, {MAX_DOFS}], got {value}")
        return tuple(range(1, value + 1))
    if not isinstance(value, list) or not value:
        raise _fail(source, "field 'dofs' must be the number of DOFs or a non-empty list of [node, direction]")
    if len(value) > MAX_DOFS:
        raise _fail(source, f"field 'dofs': {len(value)} labels are more than the {MAX_DOFS} a model may have")
    labels = []
    for i, x in enumerate(value):
        if not (isinstance(x, list) and len(x) == 2 and isinstance(x[0], int) and not isinstance(x[0], bool)):
            raise _fail(source, f"field 'dofs'[{i}]: expected [node, direction], got {shown(x)}")
        if not isinstance(x[1], str) or x[1] not in SPATIAL:
            raise _fail(source, f"field 'dofs'[{i}]: unknown direction {shown(x[1])}, use one of {list(SPATIAL)}")
        labels.append((x[0], x[1]))
    if len(set(labels)) != len(labels):
        seen, twice = set(), None
        for i, x in enumerate(labels):
            if x in seen:
                twice = i
                break
            seen.add(x)
        raise _fail(source, f"field 'dofs'[{twice}]: {list(labels[twice])} is listed twice")
    return tuple(labels)


def _term(entry, family: str, k: int, base: Path, n: int, source, seen: set) -> MatrixTerm:
    where = f"{family}[{k}]"
    if not isinstance(entry, dict):
        raise _fail(source, f"{where}: a term must be an object, got {shown(entry)}")
    check_keys(entry, TERM_KEYS, f"{source}: {where}", MatrixModelError)
    name = entry.get("name")
    if not isinstance(name, str) or not name.strip():
        raise _fail(source, f"{where}: field 'name' must be a non-empty string, got {shown(name)}")
    where = f"term {name!r} ({family}[{k}])"
    if name in seen:
        raise _fail(source, f"{where}: the name {name!r} is used twice (names are unique over stiffness and mass)")
    seen.add(name)
    numbers = {}
    for key in ("initial", "lower", "upper"):
        if key in entry:
            if not is_number(entry[key]):
                raise _fail(source, f"{where}: field '{key}' must be a finite number, got {shown(entry[key])}")
            numbers[key] = float(entry[key])
    initial = numbers.get("initial", 1.0)
    lower, upper = numbers.get("lower"), numbers.get("upper")
    if (lower is None) != (upper is None):
        raise _fail(source, f"{where}: give both 'lower' and 'upper' (a parameter) or neither (a fixed term)")
    if lower is not None:
        if not lower < upper:
            raise _fail(source, f"{where}: needs lower < upper, got [{lower:g}, {upper:g}]")
        if lower < 0:
            raise _fail(source, f"{where}: 'lower' {lower:g} < 0: a negative multiplier turns the matrix over")
        if not lower <= initial <= upper:
            raise _fail(source, f"{where}: 'initial' {initial:g} is outside [{lower:g}, {upper:g}]")
    file = entry.get("file")
    if not isinstance(file, str) or not file:
        raise _fail(source, f"{where}: field 'file' must name a matrix file")
    variable = entry.get("variable")
    if variable is not None and (not isinstance(variable, str) or not variable):
        raise _fail(source, f"{where}: field 'variable' must be a non-empty string, got {shown(variable)}")
    path = (base / file).resolve() if not Path(file).is_absolute() else Path(file)
    matrix = read_matrix(path, variable, f"{source}: {where}")
    matrix = check_matrix(matrix, n, f"{source}: {where}")
    return MatrixTerm(name, family, matrix, initial, lower, upper, str(path), variable)


def read_matrix(path: Path, variable: str | None, where: str):
    """The matrix in one file (dense ndarray or scipy sparse), by suffix; MatrixModelError
    prefixed by `where` if the file is missing, not of a known type, not readable as a matrix,
    or lacks `variable`."""
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise MatrixModelError(f"{where}: file {path.name!r}: unknown type {suffix or '(none)'!r}, use one of "
                               f"{', '.join(SUFFIXES)}")
    if not path.is_file():
        raise MatrixModelError(f"{where}: file {str(path)!r} does not exist")
    try:
        if suffix == ".mtx":
            return scipy.io.mmread(str(path))
        if suffix == ".mat":
            return _read_mat(path, variable, where)
        if suffix == ".npz":
            return _read_npz(path, variable, where)
        return _read_op4(path, variable, where)
    except MatrixModelError:
        raise
    except Exception as exc:  # a library's own complaint about a file that is not what it says
        raise MatrixModelError(f"{where}: file {path.name!r} is not a readable {suffix} matrix "
                               f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})") from None


def _read_mat(path: Path, variable, where: str):
    if variable is None:
        raise MatrixModelError(f"{where}: a .mat file needs 'variable' (the name of the matrix in {path.name!r})")
    data = scipy.io.loadmat(str(path), variable_names=[variable])
    if variable not in data:
        names = [n for n, *_ in scipy.io.whosmat(str(path))]
        raise MatrixModelError(f"{where}: file {path.name!r} has no variable {variable!r} (it has "
                               f"{', '.join(names) or 'none'})")
    return data[variable]


def _read_npz(path: Path, variable, where: str):
    with np.load(str(path), allow_pickle=False) as archive:
        names = list(archive.files)
        if variable is None and {"format", "shape", "data"} <= set(names):
            return sp.load_npz(str(path))
        if variable is None:
            if len(names) != 1:
                raise MatrixModelError(f"{where}: file {path.name!r} holds several arrays ({', '.join(names)}): "
                                       "name one with 'variable'")
            variable = names[0]
        if variable not in names:
            raise MatrixModelError(f"{where}: file {path.name!r} has no array {variable!r} (it has "
                                   f"{', '.join(names) or 'none'})")
        return archive[variable]


def _read_op4(path: Path, variable, where: str):
    if variable is None:
        raise MatrixModelError(f"{where}: a .op4 file needs 'variable' (the name of the matrix in {path.name!r})")
    try:
        from pyNastran.op4.op4 import read_op4
    except ImportError:
        from ..model.nastran import PYNASTRAN_INSTALL
        raise MatrixModelError(f"{where}: reading a .op4 file needs the 'import' extra: {PYNASTRAN_INSTALL}") from None
    matrices = read_op4(str(path), log=_quiet_log())
    if variable not in matrices:
        raise MatrixModelError(f"{where}: file {path.name!r} has no matrix {variable!r} (it has "
                               f"{', '.join(matrices) or 'none'})")
    return matrices[variable].data


def _quiet_log():
    """A logger for pyNastran that prints nothing below errors (its default prints DEBUG lines)."""
    try:
        from cpylog import SimpleLogger
        return SimpleLogger(level="error")
    except ImportError:
        return None


def check_matrix(a, n: int, where: str) -> sp.csr_matrix:
    """`a` as a symmetric float64 CSR matrix (n, n) (symmetrised exactly, (A + A^T)/2), or
    MatrixModelError prefixed by `where`: not a 2-D numeric matrix, complex, wrong size, NaN or
    infinite entries, not symmetric to `SYMMETRY_TOL`."""
    if sp.issparse(a):
        a = sp.csr_matrix(a)
    else:
        a = np.asarray(a)
        if a.dtype == object or a.dtype.kind not in "biufc":
            raise MatrixModelError(f"{where}: not a numeric matrix (type {a.dtype})")
    if a.ndim != 2:
        raise MatrixModelError(f"{where}: not a matrix (an array of {a.ndim} dimension(s), shape {a.shape})")
    if a.dtype.kind == "c":
        imag = np.abs(a.imag).max() if a.size else 0.0
        if imag > 0:
            raise MatrixModelError(f"{where}: complex entries (largest imaginary part {imag:.3g}): the matrix must be real")
        a = a.real
    if a.shape != (n, n):
        raise MatrixModelError(f"{where}: size {a.shape[0]} x {a.shape[1]}, the model has {n} DOFs ({n} x {n} needed)")
    a = sp.csr_matrix(a, dtype=np.float64)
    a.sum_duplicates()
    if not np.all(np.isfinite(a.data)):
        bad = np.flatnonzero(~np.isfinite(a.data))[0]
        row = int(np.searchsorted(a.indptr, bad, side="right") - 1)
        raise MatrixModelError(f"{where}: entry ({row + 1}, {a.indices[bad] + 1}) is {a.data[bad]}: every entry must be finite")
    a.eliminate_zeros()
    scale = np.abs(a.data).max() if a.nnz else 0.0
    if scale == 0.0:
        raise MatrixModelError(f"{where}: every entry is zero")
    asym = abs(a - a.T)
    worst = asym.max() if asym.nnz else 0.0
    if worst > SYMMETRY_TOL * scale:
        coo = asym.tocoo()
        i = int(np.argmax(coo.data))
        raise MatrixModelError(f"{where}: not symmetric: entries ({coo.row[i] + 1}, {coo.col[i] + 1}) and its mirror "
                               f"differ by {worst:.3g}, {worst / scale:.2g} of the largest entry (at most "
                               f"{SYMMETRY_TOL:g} allowed)")
    sym = ((a + a.T) * 0.5).tocsr()
    sym.sort_indices()
    return sym


def check_definite(model: MatrixModel) -> None:
    """MatrixModelError naming the manifest and the matrix if K or M at the initial values is
    not positive semi-definite (a negative diagonal entry, else a Cholesky factorisation of
    the matrix shifted by `PSD_TOL` of its largest diagonal entry fails), or if a DOF has
    neither stiffness nor mass (nothing would hold it)."""
    k, m = model.total("stiffness"), model.total("mass")
    for family, a in (("stiffness", k), ("mass", m)):
        d = a.diagonal()
        terms = [repr(t.name) for t in (model.stiffness if family == "stiffness" else model.mass)]
        what = ("K" if family == "stiffness" else "M") + f" ({'term' if len(terms) == 1 else 'the sum of terms'} " \
            f"{', '.join(terms)})"
        if np.any(d < 0):
            i = int(np.argmin(d))
            raise _fail(model.source, f"{what} at the initial values is not positive "
                                      f"semi-definite: diagonal entry {i + 1} ({_label(model, i)}) is {d[i]:.6g} < 0")
        if not _semi_definite(a, PSD_TOL * max(d.max(), 0.0)):
            raise _fail(model.source, f"{what} at the initial values is not positive "
                                      f"semi-definite (an eigenvalue below -{PSD_TOL:g} of its largest diagonal entry)")
    empty = np.flatnonzero((k.diagonal() == 0) & (m.diagonal() == 0))
    if empty.size:
        raise _fail(model.source, f"{empty.size} DOF(s) have neither stiffness nor mass at the initial values "
                                  f"({', '.join(_label(model, i) for i in empty[:4])}{' ...' if empty.size > 4 else ''}): "
                                  "remove them from the matrices")


def _label(model: MatrixModel, i: int) -> str:
    d = model.dofs[i]
    return f"node {d[0]} {d[1]}" if isinstance(d, tuple) else f"row {d}"


def _semi_definite(a: sp.csr_matrix, shift: float) -> bool:
    """Whether A + shift I is positive definite (so A has no eigenvalue below -shift):
    CHOLMOD's LDL^T (every D > 0), or a dense eigenvalue check without scikit-sparse."""
    n = a.shape[0]
    b = (a + sp.identity(n, format="csr") * max(shift, np.finfo(float).tiny)).tocsc()
    try:
        from sksparse import cholmod
    except ImportError:
        cholmod = None
    if cholmod is not None:
        try:
            factor = cholmod.cholesky(b, mode="simplicial")
        except cholmod.CholmodNotPositiveDefiniteError:
            return False
        return bool(np.all(factor.D() > 0.0))
    from scipy.sparse.linalg import splu
    try:  # SuperLU: the signs of U's diagonal with no pivoting are the inertia of a symmetric matrix
        lu = splu(b, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    except RuntimeError:
        return False
    return bool(np.all(lu.U.diagonal() > 0.0))


def save_matrix_model(model: MatrixModel, path: str | Path, copy_files: bool = False) -> Path:
    """Write `model`'s manifest to `path` with each term's `initial` as it is in the model (an
    updated model's values); returns the path. Matrix files are referenced by their path
    relative to the new manifest, or with `copy_files` copied beside it; a term made in memory
    (no file) is written beside it as ``<manifest stem>.<term>.npz``."""
    path = Path(path)
    folder = path.parent
    stem = path.name.split(".")[0] or "model"
    copied: dict[str, str] = {}
    terms = {f: [] for f in FAMILIES}
    for t in model.terms:
        entry: dict = {"name": t.name}
        if t.file is None:
            target = folder / f"{stem}.{t.name}.npz"
            with open_binary(target) as fh:
                sp.save_npz(fh, t.matrix)
            entry["file"] = target.name
        elif copy_files:
            if t.file not in copied:  # one copy per file; two files of one name get distinct names
                source = Path(t.file)
                target, k = folder / source.name, 1
                while target.name in copied.values():
                    target, k = folder / f"{source.stem}-{k}{source.suffix}", k + 1
                if target.resolve() != source.resolve():
                    with open(t.file, "rb") as src, open_binary(target) as dst:
                        shutil.copyfileobj(src, dst)
                copied[t.file] = target.name
            entry["file"] = copied[t.file]
        else:
            entry["file"] = os.path.relpath(t.file, folder.resolve())
        if t.variable is not None:
            entry["variable"] = t.variable
        entry["initial"] = float(t.initial)
        if t.is_parameter:
            entry["lower"], entry["upper"] = float(t.lower), float(t.upper)
        terms[t.family].append(entry)
    dofs = [list(d) for d in model.dofs] if model.labelled else model.n_dof
    doc = {"format": MATRIX_FORMAT, "name": model.name, "dofs": dofs, "stiffness": terms["stiffness"],
           "mass": terms["mass"]}
    if model.description:
        doc["description"] = model.description
    if model.meta:
        doc["meta"] = model.meta
    text = dumps(doc) if not model.labelled else _compact_dofs(doc)
    write_text(path, text + "\n")
    return path


def _compact_dofs(doc: dict) -> str:
    """The manifest's JSON with its DOF labels one per line (a long label list stays readable)."""
    dofs = doc.pop("dofs")
    head = dumps({**doc, "dofs": None})
    lines = ",\n  ".join(json.dumps(d) for d in dofs)
    return head.replace('"dofs": null', '"dofs": [\n  ' + lines + "\n ]")


def open_binary(path: Path):
    """`path` opened for binary writing without following a link (safe_files)."""
    from ..safe_files import open_for_writing
    return open_for_writing(path, binary=True)


__all__ = ["MANIFEST_KEYS", "PSD_TOL", "SUFFIXES", "SYMMETRY_TOL", "TERM_KEYS", "check_definite", "check_matrix",
           "load_matrix_model", "matrix_model_from_dict", "read_matrix", "save_matrix_model"]
