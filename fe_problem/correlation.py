"""Test-analysis correlation: MAC, COMAC, mode pairing, frequency errors, and `correlate`,
the one correlation of a model's modes with measured ones (`UpdatingProblem.correlation` and the
diagnosis both use it).

Shapes are columns: (n_dof, n_modes). Nothing here depends on the sign or scale of a shape.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment


def pow2_scaled(a: np.ndarray, axis: int = -2) -> np.ndarray:
    """`a` with each vector along `axis` multiplied by the power of two that brings its largest
    magnitude into [0.5, 1): exact (no rounding) for any finite scale, so that a shape's scale,
    which carries no meaning, can be 1e308 or 1e-320 without overflow or underflow downstream.
    NaN entries are ignored in the scale and kept; all-zero or all-NaN vectors are left as they are."""
    a = np.asarray(a, dtype=float)
    with np.errstate(invalid="ignore"):
        # np.nanmax(np.abs(a), axis=axis, keepdims=True, initial=0.0), without its Python layer
        big = np.fmax.reduce(np.abs(a), axis=axis, keepdims=True, initial=0.0) if a.size else np.zeros(1)
    _, exp = np.frexp(np.where(np.isfinite(big) & (big > 0), big, 1.0))
    return np.ldexp(a, -exp)


def mac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Modal Assurance Criterion between the columns of a (n, p) and b (n, q): (p, q) in [0, 1].

    Broadcasts over leading batch dimensions: a (..., n, p), b (..., n, q) -> (..., p, q).
    """
    a = pow2_scaled(a)  # exact: the MAC is scale-free, and any finite scale stays finite
    return mac_scaled(a, np.sum(a * a, axis=-2), b)


def mac_scaled(a: np.ndarray, na: np.ndarray, b: np.ndarray) -> np.ndarray:
    """`mac` with `a` already through `pow2_scaled` and `na` its squared column norms
    (np.sum(a * a, axis=-2)): the same bits, for measured shapes prepared once and correlated
    with many models' (`residuals.Observations`)."""
    b = pow2_scaled(b)
    cross = np.swapaxes(a, -1, -2) @ b
    nb = np.sum(b * b, axis=-2)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = cross**2 / (na[..., :, None] * nb[..., None, :])
    # np.nan_to_num(out, nan=0.0) where needed (a zero or non-finite model shape): the check is
    # cheaper than the call on the all-finite matrices of almost every model
    return out if np.isfinite(out).all() else np.nan_to_num(out, nan=0.0)


def comac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Coordinate MAC per DOF over paired modes (columns of a and b in pair order): (n,).

    COMAC_j = (sum_i |a_ji b_ji|)^2 / (sum_i a_ji^2 sum_i b_ji^2), with every mode pair first
    scaled and signed to agree (modal scale factor), so the result is sign- and scale-free.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.shape != b.shape:
        raise ValueError(f"comac needs paired shapes of one shape, got {a.shape} and {b.shape}")
    a, b = pow2_scaled(a, axis=0), pow2_scaled(b, axis=0)
    a = a / np.linalg.norm(a, axis=0)
    b = b / np.linalg.norm(b, axis=0)
    b = b * np.sign(np.sum(a * b, axis=0))
    num = np.sum(a * b, axis=1) ** 2
    den = np.sum(a * a, axis=1) * np.sum(b * b, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.nan_to_num(num / den, nan=0.0)


@dataclass(frozen=True)
class Pairing:
    """Measured mode i pairs with model mode `model_index[i]` (-1: unpaired).

    `by` says how each pair was made: ``"mac"`` or ``"frequency"``; `mac` is the MAC of the
    pair (NaN where no shape was measured)."""

    model_index: np.ndarray
    by: tuple[str, ...]
    mac: np.ndarray

    @property
    def paired(self) -> np.ndarray:
        return self.model_index >= 0


#: A measured mode with a shape pairs only with a model mode of at least this MAC.
MIN_PAIR_MAC = 0.5
#: A measured mode without a shape pairs only with a model mode within this relative distance.
MAX_PAIR_FREQ = 0.3


def pair_modes(measured_hz: np.ndarray, model_hz: np.ndarray, measured_shapes: np.ndarray | None = None,
               model_shapes: np.ndarray | None = None, has_shape: np.ndarray | None = None,
               min_mac: float = MIN_PAIR_MAC, max_freq_ratio: float = MAX_PAIR_FREQ) -> Pairing:
    """Pair measured modes with model modes, each model mode used at most once.

    One optimal assignment (Hungarian) over all measured modes: the cost of a pair is
    1 - MAC (plus 0.01 x the relative frequency distance, to break near-ties) for a mode with
    a measured shape, and the relative frequency distance for one without. Pairs with a MAC
    below `min_mac`, or (frequency only) further than `max_freq_ratio`, are refused: -1.
    """
    measured_hz = np.asarray(measured_hz, dtype=float)
    model_hz = np.asarray(model_hz, dtype=float)
    m = measured_hz.shape[0]
    has_shape = np.zeros(m, bool) if has_shape is None or measured_shapes is None else np.asarray(has_shape, bool)
    mm = np.full((m, model_hz.shape[0]), np.nan)
    if has_shape.any():
        mm[has_shape] = mac(np.nan_to_num(np.asarray(measured_shapes, dtype=float)[:, has_shape]), model_shapes)
    index = pair_index(measured_hz, model_hz[None], mm[None], has_shape, min_mac, max_freq_ratio)[0]
    by = tuple("none" if index[i] < 0 else ("mac" if has_shape[i] else "frequency") for i in range(m))
    macs = np.full(m, np.nan)
    for i in np.flatnonzero(has_shape):
        macs[i] = mm[i, index[i]] if index[i] >= 0 else np.nanmax(mm[i])
    return Pairing(index, by, macs)


def pair_index(measured_hz: np.ndarray, model_hz: np.ndarray, mm: np.ndarray, has_shape: np.ndarray,
               min_mac: float = MIN_PAIR_MAC, max_freq_ratio: float = MAX_PAIR_FREQ) -> np.ndarray:
    """`pair_modes`' model_index for a batch of models at once: model frequencies (b, k) and the
    MAC of each measured mode with each model mode (b, m, k; read only in the rows of
    `has_shape`), -> (b, m). The rule is `pair_modes`'; the costs are built for the whole batch
    and one assignment is solved per model."""
    dist = np.abs(model_hz[:, None, :] - measured_hz[None, :, None]) / measured_hz[None, :, None]
    cost = dist.copy()
    allowed = dist <= max_freq_ratio
    if has_shape.any():
        cost[:, has_shape] = 1.0 - mm[:, has_shape] + 0.01 * dist[:, has_shape]
        allowed[:, has_shape] = mm[:, has_shape] >= min_mac
    costs = np.where(allowed, cost, 1e6)
    index = np.full(dist.shape[:2], -1)
    for b in range(dist.shape[0]):
        rows, cols = linear_sum_assignment(costs[b])
        ok = allowed[b, rows, cols]
        index[b, rows[ok]] = cols[ok]
    return index


def frequency_errors_pct(measured_hz: np.ndarray, model_hz: np.ndarray) -> np.ndarray:
    """Signed error of the model in percent of the measured frequency: 100 (f_model - f_meas) / f_meas."""
    measured_hz = np.asarray(measured_hz, dtype=float)
    return 100.0 * (np.asarray(model_hz, dtype=float) - measured_hz) / measured_hz


@dataclass(frozen=True, eq=False)
class Correlation:
    """A model's modes against measured ones, one entry per measured mode (in measured order).

    measured_hz, model_hz (Hz; NaN where unpaired), error_pct (% of the measured frequency) and
    mac (NaN without a measured shape or a pair): (m,); model_index: the paired model mode,
    0-based, -1 where unpaired (m,); comac: (n_coord,) over the paired modes with a measured
    shape (None without any); mac_matrix: measured x model (m, k), None without shapes.
    """

    measured_hz: np.ndarray
    model_hz: np.ndarray
    error_pct: np.ndarray
    mac: np.ndarray
    comac: np.ndarray | None
    mac_matrix: np.ndarray | None
    model_index: np.ndarray

    @property
    def paired(self) -> np.ndarray:
        """(m,) bool: the measured mode pairs with a model mode."""
        return self.model_index >= 0

    @property
    def paired_model_mode(self) -> np.ndarray:
        """(m,) the paired model mode, 1-based; -1 where unpaired."""
        return np.where(self.paired, self.model_index + 1, -1)

    @property
    def mean_abs_error_pct(self) -> float | None:
        """Mean |frequency error| over the paired modes, %; None when none paired."""
        return float(np.nanmean(np.abs(self.error_pct))) if self.paired.any() else None

    @property
    def mean_mac(self) -> float | None:
        """Mean MAC over the paired modes with a measured shape; None without any."""
        return float(np.nanmean(self.mac)) if np.isfinite(self.mac).any() else None

    @property
    def mean_comac(self) -> float | None:
        """Mean COMAC over the measured coordinates; None without shapes."""
        return None if self.comac is None else float(np.mean(self.comac))

    def to_dict(self) -> dict:
        """The per-mode view as the diagnosis record writes it (arrays; NaN left to the JSON edge)."""
        return {"measured_hz": self.measured_hz, "model_hz": self.model_hz, "error_pct": self.error_pct,
                "mean_abs_error_pct": self.mean_abs_error_pct, "mac": self.mac, "mean_mac": self.mean_mac,
                "comac": self.comac, "mean_comac": self.mean_comac, "paired_model_mode": self.paired_model_mode}


def correlate(model_hz: np.ndarray, model_shapes: np.ndarray | None, measured, pairing=None) -> Correlation:
    """Correlate one model's modes with measured modes.

    model_hz: (k,) model frequencies in Hz; model_shapes: (n_coord, k) the model's shapes at the
    measured coordinates (None when no shapes were measured); measured: the measured modes, any
    object with `frequencies_hz` (m,), `shapes` (n_coord, m; NaN where not measured) and
    `has_shape` (m,), such as a `ModalData`; pairing: the model mode of each measured mode (a
    `Pairing` or an index array, -1 unpaired), by default `pair_modes` afresh.
    """
    measured_hz = np.array(measured.frequencies_hz, dtype=float)
    model_hz = np.asarray(model_hz, dtype=float)
    has_shape = np.asarray(measured.has_shape, dtype=bool)
    if pairing is None:
        pairing = pair_modes(measured_hz, model_hz, measured.shapes, model_shapes, has_shape)
    index = np.asarray(getattr(pairing, "model_index", pairing), dtype=int)
    ok = index >= 0
    paired_hz = np.where(ok, model_hz[np.clip(index, 0, None)], np.nan)
    macs = np.full(measured_hz.shape[0], np.nan)
    matrix = cm = None
    if has_shape.any():
        matrix = mac(np.nan_to_num(np.asarray(measured.shapes, dtype=float)), model_shapes)
        sel = has_shape & ok
        if sel.any():
            measured_sel, model_sel = measured.shapes[:, sel], model_shapes[:, index[sel]]
            macs[sel] = np.diagonal(mac(measured_sel, model_sel))
            cm = comac(measured_sel, model_sel)
    return Correlation(measured_hz, paired_hz, frequency_errors_pct(measured_hz, paired_hz), macs, cm, matrix, index)
