"""`identify`: FRFs -> stable physical poles -> residues -> real normal modes -> ModalData.

Steps: the band's lines; LSCF poles at orders 1..max_order (sdypy-EMA); the stabilisation
chart with residues by a windowed fit at every order; clustering of the stable poles and the choice of
the physical ones (poles.py); each mode's residues from a least-squares fit on a window
around its peak with the poles near it (shapes.py; the global LSFD with lower and upper
residuals is the synthesised fit of the report); real normal modes from the complex residues (sdypy-EMA,
Ahmadian-Gladwell-Ismail); mass-normalised through the driving point when the reference is
measured. The spread of each mode over its stable orders is its uncertainty (in `meta`).
"""

from __future__ import annotations

import math

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import poles as P
from .frf_io import FRFFileError, FRFSet
from .shapes import normal_shapes, windowed_residues

#: The fewest frequency lines in the band per requested mode (and for any identification)
LINES_PER_MODE = 20
#: A mode must lie this many half-power half-widths (zeta f) inside the band
EDGE_HALF_WIDTHS = 2.0
#: A mode whose half-power bandwidth spans fewer lines than this gets a warning
MIN_HALF_POWER_LINES = 2.0


@dataclass(frozen=True, eq=False)
class Identification:
    """What `identify` found: data (ModalData, femu.modal-data/1), chart (poles.Chart), the
    band-limited frequency_hz (n_lines,), measured frf and the synthesised fit (n_channels,
    n_lines) over it, complex residues (n_channels, n_modes), mpc (n_modes,), warnings."""

    data: object
    chart: P.Chart
    frequency_hz: np.ndarray
    frf: np.ndarray
    fit: np.ndarray
    residues: np.ndarray
    mpc: np.ndarray
    warnings: tuple[str, ...]

    @property
    def frf_sum(self) -> np.ndarray:
        """(n_lines,) sum over channels of |H|, the usual overview of a test."""
        return np.abs(self.frf).sum(0)


def _band(frfs: FRFSet, band_hz, n_modes):
    """Band (lo, hi) in Hz and the mask of its lines, checked against the file."""
    f = frfs.frequency_hz
    lo, hi = (float(f[0]), float(f[-1])) if band_hz is None else (float(band_hz[0]), float(band_hz[1]))
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"--band {lo} {hi}: two finite frequencies (Hz), the low end below the high end")
    if hi <= f[0] or lo >= f[-1]:
        raise ValueError(f"--band {lo} {hi} Hz lies outside the measured lines of {frfs.sources[0]} "
                         f"({f[0]:g} to {f[-1]:g} Hz)")
    keep = (f >= lo) & (f <= hi)
    need = LINES_PER_MODE * max(1, n_modes or 1)
    if keep.sum() < need:
        what = f"{n_modes} modes" if n_modes else "a mode"
        raise FRFFileError(f"{frfs.channel_label(0)} (and every channel: one frequency axis): too few lines per mode: "
                           f"{int(keep.sum())} lines in {lo:g}-{hi:g} Hz, {need} needed for {what} "
                           f"({LINES_PER_MODE} per mode); measure a finer resolution or a wider band")
    return (max(lo, float(f[0])), min(hi, float(f[-1]))), keep


def check_coordinates(frfs: FRFSet, model) -> None:
    """Raise FRFFileError naming file and channel if a channel's or the reference's node is not
    in `model`, or its direction is not one of the model's nodal DOFs (its layout's)."""
    ids, names = set(model.node_ids), model.layout.names
    for k, (node, d) in enumerate(frfs.coordinates):
        if node not in ids:
            raise FRFFileError(f"{frfs.channel_label(k)}: node {node} is not in model {model.name!r} "
                               f"(its nodes: {min(ids)}..{max(ids)})")
        if d not in names:
            raise FRFFileError(f"{frfs.channel_label(k)}: direction {d!r} is not a DOF of model {model.name!r} "
                               f"(its nodes have {', '.join(names)})")
    if frfs.reference[0] not in ids:
        raise FRFFileError(f"{frfs.sources[0]}: reference node {frfs.reference[0]} is not in model {model.name!r}")
    if frfs.reference[1] not in names:
        raise FRFFileError(f"{frfs.sources[0]}: reference direction {frfs.reference[1]!r} is not a DOF of model "
                           f"{model.name!r} (its nodes have {', '.join(names)})")


def _inside(chart: P.Chart, lo: float, hi: float) -> tuple[list, list]:
    """The chosen clusters whose peak lies inside the band by EDGE_HALF_WIDTHS half-power half-widths
    (zeta f), and a warning for each one dropped: a mode cut by the band edge is poorly estimated
    (its pole drifts into the band, 1 % low for a band ending on the H-frame's 8th peak)."""
    labels, warn = [], []
    for lab in chart.chosen:
        m = chart.cluster == lab
        f, z = np.median(chart.frequency_hz[m]), np.median(chart.damping[m])
        if lo <= f - EDGE_HALF_WIDTHS * z * f and f + EDGE_HALF_WIDTHS * z * f <= hi:
            labels.append(lab)
        else:
            warn.append(f"a mode at {f:.4g} Hz (damping {100 * z:.2g} %) lies within {EDGE_HALF_WIDTHS:g} half-power "
                        f"half-widths of the band edge and was dropped: widen the band to identify it")
    return labels, warn


def _uncertainty(chart: P.Chart, lab: int, shape: np.ndarray) -> dict:
    """Spread of one chosen cluster over its stable orders."""
    m = chart.cluster == lab
    f, z = chart.frequency_hz[m], chart.damping[m]
    unit = shape / np.abs(shape).max()  # MAC is scale-free; shapes of 1e100 would overflow its products
    macs = P.mac_complex(chart.residues[m], unit[None, :].astype(complex))[:, 0]
    return {"frequency_std_hz": float(f.std(ddof=1)), "frequency_std_pct": float(100 * f.std(ddof=1) / np.median(f)),
            "damping_std": float(z.std(ddof=1)), "mac_min": float(macs.min()), "n_orders": int(m.sum()),
            "orders": [int(chart.order[m].min()), int(chart.order[m].max())]}


def identify(frfs: FRFSet, model=None, band_hz=None, n_modes: int | None = None, max_order: int = P.MAX_ORDER,
             max_damping: float = P.MAX_DAMPING, progress=None) -> Identification:
    """Identify the modes in FRFs (an FRFSet from `read_frf` or `synthetic_frf`).

    model: FrameModel, name or file (default: the one the FRFs name); band_hz (lo, hi) Hz (default:
    every line); n_modes: keep the lowest N stable physical modes (default: all); max_order: highest
    LSCF order in pole pairs; max_damping: the largest physical damping ratio; progress(done, total):
    called per order of the stabilisation. Returns an Identification whose `data` is ModalData
    (frequencies Hz, real shapes at the measured coordinates, per-mode damping and uncertainty in meta).
    """
    from fe_problem import ModalData, load_model
    if not (isinstance(max_order, int) and 1 <= max_order <= P.MAX_ORDER_LIMIT):
        raise ValueError(f"--max-order: must be a whole number from 1 to {P.MAX_ORDER_LIMIT}, got {max_order!r}")
    named_by_file = model is None
    if model is None:
        if not frfs.model:
            raise FRFFileError(f"{frfs.sources[0]}: the FRF file names no model (UFF ID line 1 'model: NAME', "
                               "or a model field); pass --model")
        model = frfs.model
        beside = Path(frfs.sources[0]).parent / model  # a model file path is relative to the FRF file
        if not Path(model).is_absolute() and beside.is_file():
            model = str(beside)
    model_ref = model if isinstance(model, str) else model.name
    try:
        model = load_model(model)
    except (ValueError, FileNotFoundError) as exc:  # the model the FRF file names: say which file named it
        if not named_by_file:
            raise
        raise FRFFileError(f"{frfs.sources[0]}: field 'model' {model_ref!r}: {exc}") from None
    check_coordinates(frfs, model)
    (lo, hi), keep = _band(frfs, band_hz, n_modes)
    # The fits run on FRFs scaled by a power of two to a largest magnitude near 1 (exact, and
    # undone on the residues): FRFs of 1e-200 or 1e200 m/s^2/N would otherwise underflow or
    # overflow the least-squares systems.
    scale = 2.0 ** -np.round(np.log2(np.abs(frfs.frf).max()))
    freq, frf = frfs.frequency_hz[keep], frfs.frf[:, keep] * scale
    try:
        per_order = P.lscf_poles(frfs.frequency_hz, frfs.frf * scale, (lo, hi), frfs.form, max_order)
        chart = P.select(P.stabilisation(freq, frf, frfs.form, per_order, progress, max_damping=max_damping),
                         max_damping=max_damping)
    except (np.linalg.LinAlgError, FloatingPointError) as exc:
        raise FRFFileError(f"{', '.join(frfs.sources)}: the pole fit failed ({exc}) in {lo:g}-{hi:g} Hz: the FRFs "
                           "hold no resonance there, or a channel is constant or pure noise") from None
    labels, warn = _inside(chart, lo, hi)
    if n_modes is not None and len(labels) < n_modes:
        warn.append(f"asked for {n_modes} modes, found {len(labels)} stable physical modes in {lo:g}-{hi:g} Hz")
    labels = labels[:n_modes] if n_modes else labels
    if not labels:
        hint = (f"; the band starts at {lo / hi:.0%} of its top, and the LSCF (sdypy-EMA) maps 0 Hz to the top "
                "onto the unit circle: widen the band downwards" if lo > 0.3 * hi else "")
        raise ValueError(f"{frfs.sources[0]}: no stable physical mode found in {lo:g}-{hi:g} Hz "
                         f"(orders 1-{max_order}, damping below {max_damping}){hint}")
    fr = np.array([np.median(chart.frequency_hz[chart.cluster == lab]) for lab in labels])
    zr = np.array([np.median(chart.damping[chart.cluster == lab]) for lab in labels])
    modal_poles = P.complex_pole(fr, zr)
    fit = P.lsfd(modal_poles, freq, frf, frfs.form)[1] / scale
    scaled_residues = windowed_residues(modal_poles, freq, frf, frfs.form)
    residues, frf = scaled_residues / scale, frf / scale
    driving = frfs.coordinates.index(frfs.reference) if frfs.reference in frfs.coordinates else None
    shapes, scaling = normal_shapes(scaled_residues, modal_poles, driving)
    if driving is not None:  # mass-normalised shapes go with the square root of the FRFs' scale
        shapes = shapes / np.sqrt(scale)
    df = freq[1] - freq[0]
    for k in np.flatnonzero(2 * zr * fr / df < MIN_HALF_POWER_LINES):
        warn.append(f"mode {k + 1} ({fr[k]:.4g} Hz): its half-power bandwidth spans {2 * zr[k] * fr[k] / df:.2g} "
                    f"lines; its damping is poorly resolved")
    unc = [_uncertainty(chart, lab, shapes[:, k]) for k, lab in enumerate(labels)]
    meta = {"source": "femu identify (LSCF poles, LSFD residues; sdypy-EMA) of " + ", ".join(frfs.sources),
            "frf_files": list(frfs.sources), "reference": list(frfs.reference), "band_hz": [lo, hi],
            "form": frfs.form, "units": frfs.units, "n_lines": int(freq.size), "resolution_hz": float(df),
            "max_order": int(max_order), "damping_ratio": zr.tolist(), "mpc": P.mpc(scaled_residues.T).tolist(),
            "scaling": scaling, "uncertainty": unc, "warnings": warn}
    data = ModalData(model_ref, frfs.coordinates, fr, shapes, meta, source=frfs.sources[0])
    return Identification(data, chart, freq, frf, fit, residues, P.mpc(scaled_residues.T), tuple(warn))
