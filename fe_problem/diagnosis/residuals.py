"""Residuals between measured modes and a model's modes, weighted by a noise model.

The noise model is the one a modal test states: relative frequency error `freq_noise`
(std, e.g. 0.002 for 0.2 %) and shape error `shape_noise` (std of each measured entry as a
fraction of the mode's RMS at the measured coordinates). Under it the weighted residuals
are standard normal, so chi^2 = ||r||^2 is a log-likelihood and differences of chi^2 are
likelihood-ratio statistics.

Residuals of one mode pair: (f_model - f_meas) / (f_meas freq_noise) and, where a shape was
measured, the difference of the two shapes at the measured coordinates, each scaled to unit
length and signed to agree, divided by shape_noise / sqrt(n_coordinates).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..correlation import mac
from ..data import ModalData

#: A measured mode with a shape pairs only with a model mode of at least this MAC.
MIN_PAIR_MAC = 0.5
#: A measured mode without a shape pairs only with a model mode within this relative distance.
MAX_PAIR_FREQ = 0.3


@dataclass(frozen=True, eq=False)
class Observations:
    """The measured modes a fit uses, unit-normalised, with the noise model."""

    frequencies_hz: np.ndarray   # (m,)
    shapes: np.ndarray           # (n_coord, m) unit columns, NaN where not measured
    has_shape: np.ndarray        # (m,)
    freq_noise: float
    shape_noise: float

    @classmethod
    def of(cls, data: ModalData, modes=None, freq_noise: float = 0.002, shape_noise: float = 0.02):
        modes = np.arange(data.n_modes) if modes is None else np.asarray(modes, dtype=int)
        shapes = data.shapes[:, modes]
        with np.errstate(invalid="ignore"):
            shapes = shapes / np.linalg.norm(shapes, axis=0)
        return cls(data.frequencies_hz[modes], shapes, ~np.isnan(shapes).any(axis=0),
                   float(freq_noise), float(shape_noise))

    @property
    def n_modes(self) -> int:
        return int(self.frequencies_hz.shape[0])

    @property
    def n_residuals(self) -> int:
        return self.n_modes + int(self.has_shape.sum()) * self.shapes.shape[0]

    def pair(self, model_hz: np.ndarray, model_shapes: np.ndarray) -> np.ndarray:
        """Model mode index for each measured mode (-1: none), one model mode at most once.

        An optimal assignment (Hungarian) on a cost of 1 - MAC for modes with shapes and the
        relative frequency distance otherwise; pairs beyond MIN_PAIR_MAC / MAX_PAIR_FREQ are
        refused."""
        dist = np.abs(model_hz[None, :] - self.frequencies_hz[:, None]) / self.frequencies_hz[:, None]
        cost = dist.copy()
        allowed = dist <= MAX_PAIR_FREQ
        if self.has_shape.any():
            mm = mac(np.nan_to_num(self.shapes[:, self.has_shape]), model_shapes)
            cost[self.has_shape] = 1.0 - mm + 0.01 * dist[self.has_shape]
            allowed[self.has_shape] = mm >= MIN_PAIR_MAC
        cost = np.where(allowed, cost, 1e6)
        rows, cols = linear_sum_assignment(cost)
        out = np.full(self.n_modes, -1)
        ok = allowed[rows, cols]
        out[rows[ok]] = cols[ok]
        return out

    def residuals(self, model_hz: np.ndarray, model_shapes: np.ndarray, pairing: np.ndarray | None = None):
        """Weighted residual vector for one model (its frequencies (k,) and shapes at the
        measured coordinates (n_coord, k)); pairs afresh unless `pairing` is given.

        Returns (r, pairing). An unpaired measured mode contributes a large fixed residual
        (as if 30 % off in frequency and orthogonal in shape) so that no fit can gain by
        losing a mode."""
        idx = self.pair(model_hz, model_shapes) if pairing is None else pairing
        ok = idx >= 0
        f = np.where(ok, model_hz[np.clip(idx, 0, None)], self.frequencies_hz * (1 + MAX_PAIR_FREQ))
        r_f = (f - self.frequencies_hz) / (self.frequencies_hz * self.freq_noise)
        if not self.has_shape.any():
            return r_f, idx
        sel = self.has_shape
        u_a = model_shapes[:, np.clip(idx[sel], 0, None)]
        u_a = u_a / np.linalg.norm(u_a, axis=0)
        u_m = self.shapes[:, sel]
        u_a = u_a * np.where(np.sum(u_a * u_m, axis=0) < 0, -1.0, 1.0)
        u_a = np.where(ok[sel][None, :], u_a, 0.0)
        sigma = self.shape_noise / np.sqrt(u_m.shape[0])
        return np.concatenate([r_f, ((u_a - u_m) / sigma).ravel(order="F")]), idx
