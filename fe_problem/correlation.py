"""Test-analysis correlation: MAC, COMAC, mode pairing, frequency errors.

Shapes are columns: (n_dof, n_modes). Nothing here depends on the sign or scale of a shape.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment


def mac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Modal Assurance Criterion between the columns of a (n, p) and b (n, q): (p, q) in [0, 1].

    Broadcasts over leading batch dimensions: a (..., n, p), b (..., n, q) -> (..., p, q).
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    cross = np.swapaxes(a, -1, -2) @ b
    na = np.sum(a * a, axis=-2)
    nb = np.sum(b * b, axis=-2)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = cross**2 / (na[..., :, None] * nb[..., None, :])
    return np.nan_to_num(out, nan=0.0)


def comac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Coordinate MAC per DOF over paired modes (columns of a and b in pair order): (n,).

    COMAC_j = (sum_i |a_ji b_ji|)^2 / (sum_i a_ji^2 sum_i b_ji^2), with every mode pair first
    scaled and signed to agree (modal scale factor), so the result is sign- and scale-free.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.shape != b.shape:
        raise ValueError(f"comac needs paired shapes of one shape, got {a.shape} and {b.shape}")
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
    dist = np.abs(model_hz[None, :] - measured_hz[:, None]) / measured_hz[:, None]
    cost = dist.copy()
    allowed = dist <= max_freq_ratio
    mm = np.full(dist.shape, np.nan)
    if has_shape.any():
        mm[has_shape] = mac(np.nan_to_num(np.asarray(measured_shapes, dtype=float)[:, has_shape]), model_shapes)
        cost[has_shape] = 1.0 - mm[has_shape] + 0.01 * dist[has_shape]
        allowed[has_shape] = mm[has_shape] >= min_mac
    rows, cols = linear_sum_assignment(np.where(allowed, cost, 1e6))
    index = np.full(m, -1)
    ok = allowed[rows, cols]
    index[rows[ok]] = cols[ok]
    by = tuple("none" if index[i] < 0 else ("mac" if has_shape[i] else "frequency") for i in range(m))
    macs = np.full(m, np.nan)
    for i in np.flatnonzero(has_shape):
        macs[i] = mm[i, index[i]] if index[i] >= 0 else np.nanmax(mm[i])
    return Pairing(index, by, macs)


def frequency_errors_pct(measured_hz: np.ndarray, model_hz: np.ndarray) -> np.ndarray:
    """Signed error of the model in percent of the measured frequency: 100 (f_model - f_meas) / f_meas."""
    measured_hz = np.asarray(measured_hz, dtype=float)
    return 100.0 * (np.asarray(model_hz, dtype=float) - measured_hz) / measured_hz
