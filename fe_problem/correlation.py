"""Test-analysis correlation: MAC, COMAC, mode pairing, frequency errors.

Shapes are columns: (n_dof, n_modes). Nothing here depends on the sign or scale of a shape.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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


def pair_modes(measured_hz: np.ndarray, model_hz: np.ndarray, measured_shapes: np.ndarray | None = None,
               model_shapes: np.ndarray | None = None, has_shape: np.ndarray | None = None,
               min_mac: float = 0.5, max_freq_ratio: float = 0.3) -> Pairing:
    """Pair measured modes with model modes, each model mode used at most once.

    Modes with a measured shape pair by MAC, greedily from the highest MAC down, only if the
    MAC is at least `min_mac`. Modes without a shape then pair with the nearest free model
    frequency, only if it lies within `max_freq_ratio` relative distance. Unpaired: -1.
    """
    measured_hz = np.asarray(measured_hz, dtype=float)
    model_hz = np.asarray(model_hz, dtype=float)
    m = measured_hz.shape[0]
    has_shape = np.zeros(m, bool) if has_shape is None or measured_shapes is None else np.asarray(has_shape, bool)
    index = np.full(m, -1)
    by = ["none"] * m
    macs = np.full(m, np.nan)
    used: set[int] = set()
    if has_shape.any():
        mm = mac(measured_shapes, model_shapes)
        order = np.dstack(np.unravel_index(np.argsort(-mm, axis=None), mm.shape))[0]
        for i, j in order:
            if not has_shape[i] or index[i] >= 0 or j in used or mm[i, j] < min_mac:
                continue
            index[i], by[i], macs[i] = j, "mac", mm[i, j]
            used.add(int(j))
        for i in np.flatnonzero(has_shape):
            macs[i] = mm[i, index[i]] if index[i] >= 0 else mm[i].max()
    for i in np.flatnonzero(~has_shape):
        rel = np.abs(model_hz - measured_hz[i]) / measured_hz[i]
        rel[list(used)] = np.inf
        j = int(np.argmin(rel))
        if rel[j] <= max_freq_ratio:
            index[i], by[i] = j, "frequency"
            used.add(j)
    return Pairing(index, tuple(by), macs)


def frequency_errors_pct(measured_hz: np.ndarray, model_hz: np.ndarray) -> np.ndarray:
    """Signed error of the model in percent of the measured frequency: 100 (f_model - f_meas) / f_meas."""
    measured_hz = np.asarray(measured_hz, dtype=float)
    return 100.0 * (np.asarray(model_hz, dtype=float) - measured_hz) / measured_hz
