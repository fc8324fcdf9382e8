"""Measured response time series (ambient or operational tests) on disk: CSV and `.npz`.

The format is ../shared/formats/time-series.md (docs/identify-ambient.md): one
channel per measured coordinate, labelled ``NODE:DIRECTION`` (``37:x``) or, for a model given
as matrices, a 1-based DOF number; accelerations in m/s^2 (``units="g"`` for g).

- CSV: ``#`` comment lines first (kept as metadata), one header line (an optional first column
  ``time_s``, uniformly spaced, then the channels), one line per sample; every line has every
  column, no NaN. Without ``time_s`` the sampling frequency must be given (``fs``).
- `.npz`: ``acc`` (samples x channels), ``fs`` (Hz), ``dofs`` (the channel labels as text).

Several files are several setups of one test (roving sensors): the channels whose label is in
every file are the references that tie the setups together (`Recording.references`).

`channel_quality` names the channels that look dead (constant), clipped (flat at an extreme)
or far noisier than the others; the identification drops the first two and keeps the third
(ambient.py), and says so.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..dofs import SPATIAL
from .csv_numbers import number_table
from .frf_io import FRFFileError, _npz_sizes

#: Standard gravity, m/s^2 per g (``--units g``)
G = 9.80665
UNITS = {"m/s^2": 1.0, "g": G}
#: The largest CSV file read (bytes): 30 channels of 10 minutes at 200 Hz are about 40 MB
MAX_CSV_BYTES = 4 * 2**30
#: A time column is uniform when every step is within this fraction of the median step
TIME_TOLERANCE = 1e-6
#: A channel is clipped when at least this fraction of its samples (and at least CLIP_MIN_SAMPLES)
#: sit at its largest or smallest value (a Gaussian record reaches each extreme once)
CLIP_FRACTION = 0.002
CLIP_MIN_SAMPLES = 5
#: A channel is far noisier when its noise floor (`noise_ratio`) exceeds this multiple of the
#: median over the setup's channels (clean channels of a simulated building differ by up to 2x)
NOISE_FACTOR = 5.0


class TimeSeriesError(FRFFileError):
    """A time-series file that cannot be used; the message names the file, the line or column,
    and the problem."""


Label = "tuple[int, str] | int"


@dataclass(frozen=True, eq=False)
class Setup:
    """One file of a test: acc (n_samples, n_channels) in m/s^2, fs (Hz), channels (one label per
    column: (node, direction) or a 1-based DOF number), source (the file), comments (the CSV's
    ``#`` lines), columns (each channel's 1-based column in the file, for messages)."""

    acc: np.ndarray
    fs: float
    channels: tuple
    source: str = "<memory>"
    comments: tuple[str, ...] = ()
    columns: tuple[int, ...] = ()

    @property
    def n_samples(self) -> int:
        return int(self.acc.shape[0])

    @property
    def duration_s(self) -> float:
        return self.n_samples / self.fs

    def channel_label(self, k: int) -> str:
        """'FILE: column c (37:x)' for messages (k 0-based)."""
        col = self.columns[k] if self.columns else k + 1
        return f"{self.source}: column {col} ({label_text(self.channels[k])})"


@dataclass(frozen=True, eq=False)
class Recording:
    """The setups of one test (one or more files), one sampling frequency."""

    setups: tuple[Setup, ...]

    @property
    def fs(self) -> float:
        return self.setups[0].fs

    @property
    def sources(self) -> tuple[str, ...]:
        return tuple(s.source for s in self.setups)

    @property
    def references(self) -> tuple:
        """The labels in every setup (in the first setup's order); empty for a single setup."""
        if len(self.setups) < 2:
            return ()
        return tuple(c for c in self.setups[0].channels if all(c in s.channels for s in self.setups[1:]))

    @property
    def channels(self) -> tuple:
        """Every measured coordinate once: the first setup's, then each later setup's new ones."""
        seen: list = []
        for s in self.setups:
            seen += [c for c in s.channels if c not in seen]
        return tuple(seen)


def label_text(label) -> str:
    """'37:x' or '12' (a DOF number)."""
    return str(label) if isinstance(label, int) else f"{label[0]}:{label[1]}"


def parse_label(text: str, where: str):
    """A channel label 'NODE:DIRECTION' -> (node, direction), or 'N' -> N (a 1-based DOF number)."""
    text = text.strip()
    node, colon, d = text.partition(":")
    if not colon:
        if text.isdigit() and int(text) >= 1:
            return int(text)
        raise TimeSeriesError(f"{where}: channel label {text!r} is neither NODE:DIRECTION (e.g. 37:x) nor a 1-based "
                              "DOF number")
    if not node.strip().isdigit():
        raise TimeSeriesError(f"{where}: channel label {text!r}: node {node!r} is not a node id")
    if d.strip() not in SPATIAL:
        raise TimeSeriesError(f"{where}: channel label {text!r}: direction {d!r} is not one of {', '.join(SPATIAL)}")
    return (int(node), d.strip())


def _labels(texts, where: str) -> tuple:
    labels = []
    for k, t in enumerate(texts):
        lab = parse_label(t, f"{where} {k + 1}")
        if lab in labels:
            raise TimeSeriesError(f"{where} {k + 1}: channel {label_text(lab)} appears twice")
        labels.append(lab)
    if not labels:
        raise TimeSeriesError(f"{where.rsplit(':', 1)[0]}: no channel columns")
    if len({type(lab) for lab in labels}) > 1:
        raise TimeSeriesError(f"{where.rsplit(':', 1)[0]}: channel labels mix NODE:DIRECTION and DOF numbers")
    return tuple(labels)


def _check_fs(fs, where: str) -> float:
    try:
        fs = float(fs)
    except (TypeError, ValueError):
        raise TimeSeriesError(f"{where}: sampling frequency {fs!r} is not a number (Hz)") from None
    if not (math.isfinite(fs) and fs > 0):
        raise TimeSeriesError(f"{where}: sampling frequency {fs!r} must be a positive number (Hz)")
    return fs


def _fs_of_time(t: np.ndarray, numbers: list[int], path: Path) -> float:
    """The sampling frequency of a time column, refused unless uniformly increasing."""
    if t.size < 2:
        raise TimeSeriesError(f"{path}: column 1 (time_s): fewer than two samples")
    step = np.diff(t)
    dt = float(np.median(step))
    if not dt > 0:
        raise TimeSeriesError(f"{path}: column 1 (time_s): time does not increase (median step {dt:g} s)")
    bad = np.flatnonzero(np.abs(step - dt) > TIME_TOLERANCE * dt + 1e-12 * abs(t).max())
    if bad.size:
        k = int(bad[0]) + 1
        raise TimeSeriesError(f"{path}: line {numbers[k]}: column 1 (time_s): time not uniform: step "
                              f"{step[k - 1]:.6g} s after {t[k - 1]:.6g} s, the median step is {dt:.6g} s")
    return 1.0 / dt


def read_csv(path: str | Path, fs: float | None = None) -> Setup:
    """One setup from a CSV file in the module docstring's layout (m/s^2 as written)."""
    path = Path(path)
    if path.stat().st_size > MAX_CSV_BYTES:
        raise TimeSeriesError(f"{path}: larger than {MAX_CSV_BYTES} bytes; split the test into several files")
    try:
        lines = path.read_bytes().decode("utf-8-sig").splitlines()
    except UnicodeDecodeError as exc:
        raise TimeSeriesError(f"{path}: not UTF-8 text (byte at offset {exc.start}); save the file as UTF-8") from None
    comments, k = [], 0
    while k < len(lines) and (not lines[k].strip() or lines[k].lstrip().startswith("#")):
        if lines[k].strip():
            comments.append(lines[k].strip()[1:].strip())
        k += 1
    if k == len(lines):
        raise TimeSeriesError(f"{path}: no header line (time_s and NODE:DIRECTION columns)")
    header = [c.strip() for c in next(csv.reader([lines[k]]))]
    has_time = header[0] == "time_s"
    channels = _labels(header[1:] if has_time else header, f"{path}: line {k + 1}: column")
    numbers = [n + 1 for n in range(k + 1, len(lines)) if lines[n].strip()]
    body = [lines[n - 1] for n in numbers]
    if not body:
        raise TimeSeriesError(f"{path}: no samples after the header")
    table = number_table(list(zip(numbers, body)), header, str(path), TimeSeriesError,
                         " (unequal lengths: every line needs every column)")
    if has_time:
        fs_time = _fs_of_time(table[:, 0], numbers, path)
        if fs is not None and abs(fs - fs_time) > 1e-6 * fs:
            raise TimeSeriesError(f"{path}: column 1 (time_s) gives {fs_time:.6g} Hz but --fs is {fs:g} Hz")
        fs = fs_time
    elif fs is None:
        raise TimeSeriesError(f"{path}: no time_s column: give the sampling frequency with --fs HZ")
    acc = np.ascontiguousarray(table[:, 1:] if has_time else table)
    first = 2 if has_time else 1
    return Setup(acc, _check_fs(fs, f"{path}"), channels, str(path), tuple(comments),
                 tuple(range(first, first + len(channels))))


def read_npz(path: str | Path, fs: float | None = None) -> Setup:
    """One setup from an `.npz` file: acc (samples x channels), fs (Hz), dofs (labels)."""
    path = Path(path)
    _npz_sizes(path)
    try:
        z = np.load(path, allow_pickle=False)
    except Exception:
        raise TimeSeriesError(f"{path}: not a readable .npz file (numpy arrays without objects, as numpy.savez "
                              "writes)") from None
    if not isinstance(z, np.lib.npyio.NpzFile):
        raise TimeSeriesError(f"{path}: a single .npy array, not an .npz archive of arrays acc, fs, dofs")
    with z:
        missing = [k for k in ("acc", "fs", "dofs") if k not in z.files]
        if missing:
            raise TimeSeriesError(f"{path}: missing array(s) {missing} (acc, fs and dofs are needed)")
        acc, f, dofs = z["acc"], z["fs"], z["dofs"]
    if acc.dtype.kind not in "iuf" or acc.ndim != 2:
        raise TimeSeriesError(f"{path}: array 'acc' must be a 2-D array of real numbers (samples x channels); it is "
                              f"{acc.dtype} of shape {acc.shape}")
    if f.size != 1 or f.dtype.kind not in "iuf":
        raise TimeSeriesError(f"{path}: array 'fs' must be one number (Hz); it is {f.dtype} of shape {f.shape}")
    fs_file = _check_fs(f.reshape(()), f"{path}: array 'fs'")
    if fs is not None and abs(fs - fs_file) > 1e-6 * fs:
        raise TimeSeriesError(f"{path}: array 'fs' is {fs_file:g} Hz but --fs is {fs:g} Hz")
    if dofs.ndim != 1 or dofs.dtype.kind not in "Uiu":
        raise TimeSeriesError(f"{path}: array 'dofs' must be a 1-D array of channel labels (text '37:x' or DOF "
                              f"numbers); it is {dofs.dtype} of shape {dofs.shape}")
    channels = _labels([str(d) for d in dofs], f"{path}: array 'dofs' entry")
    if len(channels) != acc.shape[1]:
        raise TimeSeriesError(f"{path}: array 'acc' has {acc.shape[1]} channels (columns) but 'dofs' has "
                              f"{len(channels)} labels (unequal lengths)")
    bad = np.argwhere(~np.isfinite(acc))
    if bad.size:
        r, c = (int(i) for i in bad[0])
        raise TimeSeriesError(f"{path}: array 'acc' sample {r + 1}, channel {c + 1} ({label_text(channels[c])}): "
                              f"{acc[r, c]} (NaN or infinite)")
    return Setup(np.asarray(acc, float), fs_file, channels, str(path), (), tuple(range(1, len(channels) + 1)))


def read_timeseries(*paths, fs: float | None = None, units: str = "m/s^2") -> Recording:
    """The setups of one test from CSV or `.npz` files (one setup each), in m/s^2.

    fs: the sampling frequency (Hz) where a CSV has no time column (checked against the files
    that state theirs); units: 'm/s^2' or 'g'. Raises TimeSeriesError naming the file, the line
    or column and the problem."""
    if units not in UNITS:
        raise ValueError(f"--units {units!r}: one of {', '.join(UNITS)}")
    if fs is not None:
        fs = _check_fs(fs, "--fs")
    if not paths:
        raise ValueError("no time-series file given")
    setups = []
    for p in paths:
        p = Path(p)
        if not p.is_file():
            raise FileNotFoundError(f"{p}: no such file")
        reader = read_npz if p.suffix.lower() == ".npz" else read_csv
        s = reader(p, fs)
        setups.append(Setup(s.acc * UNITS[units], s.fs, s.channels, s.source, s.comments, s.columns))
    for s in setups[1:]:
        if abs(s.fs - setups[0].fs) > 1e-6 * setups[0].fs:
            raise TimeSeriesError(f"{s.source}: sampled at {s.fs:g} Hz, {setups[0].source} at {setups[0].fs:g} Hz: "
                                  "the setups of one test need one sampling frequency")
        if type(s.channels[0]) is not type(setups[0].channels[0]):
            raise TimeSeriesError(f"{s.source}: its channel labels are of another kind than {setups[0].source}'s")
    rec = Recording(tuple(setups))
    if len(setups) > 1 and not rec.references:
        raise TimeSeriesError(f"{', '.join(rec.sources)}: no channel label is in every file: several setups are "
                              "merged through reference channels that stay put (the same label in each file)")
    return rec


def noise_ratio(acc: np.ndarray, fs: float) -> np.ndarray:
    """(n_channels,) a channel's noise floor: the median of its power spectral density (Welch,
    scipy) over its largest value. A structure's response has peaks well above a low floor;
    white sensor noise lifts the floor, so a channel far noisier than the others has a far
    higher ratio (noise of the signal's own size: 5-9 times the median of clean channels)."""
    from scipy.signal import welch

    x = acc - acc.mean(0)
    _, p = welch(x, fs=fs, nperseg=max(16, min(1024, x.shape[0] // 8)), axis=0)
    return np.median(p, 0) / np.maximum(p.max(0), 1e-300)


def channel_quality(setup: Setup) -> list[tuple[int, str, str]]:
    """(channel index, kind, message) for each channel that looks 'dead' (constant), 'clipped'
    (at least CLIP_FRACTION of its samples at its largest or smallest value) or 'noisy' (its
    `noise_ratio` above NOISE_FACTOR times the setup's median)."""
    x = setup.acc
    out = []
    span = np.ptp(x, axis=0)
    scale = np.abs(x).max()
    dead = span <= 1e-12 * max(scale, 1e-300)
    need = max(CLIP_MIN_SAMPLES, CLIP_FRACTION * setup.n_samples)
    tol = 1e-9 * span
    at_top = (x >= x.max(0) - tol).sum(0)
    at_bottom = (x <= x.min(0) + tol).sum(0)
    live = np.flatnonzero(~dead)
    ratio = noise_ratio(x[:, live], setup.fs) if live.size else np.zeros(0)
    median = float(np.median(ratio)) if ratio.size > 2 else math.inf
    for k in range(x.shape[1]):
        if dead[k]:
            out.append((k, "dead", f"{setup.channel_label(k)} looks dead: constant at {x[0, k]:.6g} m/s^2"))
        elif max(at_top[k], at_bottom[k]) >= need:
            n, where = (at_top[k], "largest") if at_top[k] >= at_bottom[k] else (at_bottom[k], "smallest")
            out.append((k, "clipped", f"{setup.channel_label(k)} looks clipped: {n} samples "
                                      f"({100 * n / setup.n_samples:.2g} %) sit at its {where} value "
                                      f"{x.max(0)[k] if where == 'largest' else x.min(0)[k]:.6g} m/s^2"))
    for j, k in enumerate(live):
        if ratio[j] > NOISE_FACTOR * median and not any(o[0] == k for o in out):
            out.append((int(k), "noisy", f"{setup.channel_label(int(k))} looks far noisier than the others: its spectral noise "
                                         f"floor {ratio[j]:.2g} of its peak, {ratio[j] / median:.1f} times the median {median:.2g}"))
    return sorted(out)
