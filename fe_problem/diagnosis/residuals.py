"""Residuals between measured modes and a model's modes, weighted by a noise model.

Where the data state a mode's deviations (`frequency_std_hz`, `shape_std`,
docs/modal-data-format.md) they are that mode's noise; elsewhere the noise model applies.
The noise model is the one a modal test states: relative frequency error `freq_noise`
(std, e.g. 0.002 for 0.2 %) and shape error `shape_noise`: the std of each measured shape
entry as a fraction of the largest |entry| of that mode at the measured coordinates (the
usual convention of test rigs: "2 % shape noise" is 2 % of the peak of the mode). Under it the weighted residuals
are standard normal, so chi^2 = ||r||^2 is a log-likelihood and differences of chi^2 are
likelihood-ratio statistics.

Residuals of one mode pair: (f_model - f_meas) / (f_meas freq_noise) and, where a shape was
measured, the difference of the two shapes at the measured coordinates, each scaled to unit
length and signed to agree, divided by shape_noise * max|entry| of the unit measured shape.
A shape has one fewer degree of freedom than coordinates (its scale is free), which the
goodness-of-fit count (`dof`) takes into account.

Close modes. Where model modes lie within a few `CLOSE_MODES_REL` of each other in frequency
(a doubly symmetric building's two sway modes, its torsion beside a sway), any small effect the
model misses mixes them: the mixing angle is about the effect over the gap, so the model's shape
of each one alone predicts nothing. A measured shape paired with such a mode is compared with
the best combination of the mode and its close neighbours (`close_mode_shape`): a least-squares
fit whose neighbours' coefficients are penalised by exp((gap / CLOSE_MODES_REL)^2) - 1 (free for
equal frequencies, all but barred at 2.5 times the scale, where the neighbour is left out and
the residual is the one of the mode alone). Without it a shipped 2 x 2-bay space frame with a
column loss and a roof mass was diagnosed as a stiffness gain elsewhere: the best single
candidate was the one that turned the close pair the right way, whatever its physics.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..correlation import MAX_PAIR_FREQ, mac_scaled, pair_index, pow2_scaled
from ..modal_data import ModalData

#: Relative frequency gap (0.01: 1 %) below which model modes are mixed freely by an unmodelled
#: effect (see the module docstring); neighbours beyond `CLOSE_MODES_REACH` times it are left out.
CLOSE_MODES_REL = 0.01
#: (a neighbour at the cut would take at most 1/500 of its own shape: e^(2.5^2) - 1 = 517)
CLOSE_MODES_REACH = 2.5


def close_mode_shape(u_m: np.ndarray, model_hz: np.ndarray, model_shapes: np.ndarray, j: int) -> np.ndarray | None:
    """The unit model shape a measured unit shape `u_m` is compared with when it pairs with model
    mode `j`: mode j combined with its close neighbours (penalised least squares, see the module
    docstring), or None when mode j has no neighbour within `CLOSE_MODES_REACH` x `CLOSE_MODES_REL` (mode j alone)."""
    own = np.linalg.norm(model_shapes[:, j])
    if not (np.isfinite(model_hz[j]) and np.isfinite(own) and own > 0 and np.isfinite(u_m).all()):
        return None  # a failed solve's mode (dropped.py), or one still at the measured coordinates: no combination
    with np.errstate(divide="ignore", invalid="ignore"):
        gap = np.abs(model_hz - model_hz[j]) / model_hz[j]
    near = np.flatnonzero(gap < CLOSE_MODES_REACH * CLOSE_MODES_REL)
    norms = np.linalg.norm(model_shapes[:, near], axis=0)
    near = near[(near != j) & (norms > 0) & np.isfinite(norms)]
    if not len(near):
        return None
    b = model_shapes[:, np.concatenate([[j], near])]
    b = b / np.linalg.norm(b, axis=0)
    penalty = np.concatenate([[0.0], np.expm1((gap[near] / CLOSE_MODES_REL) ** 2)])
    try:
        c = np.linalg.lstsq(b.T @ b + np.diag(penalty), b.T @ u_m, rcond=None)[0]
    except np.linalg.LinAlgError:  # no combination found: the mode alone, as beyond reach
        return None
    u = b @ c
    norm = np.linalg.norm(u)
    return u / norm if np.isfinite(norm) and norm > 0 else None


@dataclass(frozen=True, eq=False)
class Observations:
    """The measured modes a fit uses, unit-normalised, with the noise model."""

    frequencies_hz: np.ndarray   # (m,)
    shapes: np.ndarray           # (n_coord, m) unit columns, NaN where not measured
    has_shape: np.ndarray        # (m,)
    freq_noise: float
    shape_noise: float
    #: (m,) each frequency's std relative to it: the mode's stated `frequency_std_hz` / f, else
    #: `freq_noise`; (n_coord, m) each unit shape entry's std: the stated `shape_std` scaled
    #: with the shape to unit length, else `shape_noise` x the largest |entry| (NaN: no shape)
    freq_rel_std: np.ndarray | None = None
    shape_std: np.ndarray | None = None
    #: how many modes state a frequency / shape deviation (the rest take the noise model)
    n_stated: tuple[int, int] = (0, 0)

    @classmethod
    def of(cls, data: ModalData, modes=None, freq_noise: float = 0.002, shape_noise: float = 0.02):
        """The modes `modes` of `data` (default all), the noise each states where it does
        (`ModalData.frequency_std_hz`, `shape_std`), `freq_noise`, `shape_noise` elsewhere."""
        modes = np.arange(data.n_modes) if modes is None else np.asarray(modes, dtype=int)
        raw = data.shapes[:, modes]
        shapes = pow2_scaled(raw, axis=0)  # any finite scale: no overflow below
        with np.errstate(invalid="ignore"):
            shapes = shapes / np.linalg.norm(shapes, axis=0)
        has = ~np.isnan(shapes).any(axis=0)
        f = data.frequencies_hz[modes]
        f_std = data.frequency_std_hz[modes]
        rel = np.where(np.isnan(f_std), float(freq_noise), f_std / f)
        s_std = data.shape_std[:, modes]
        with np.errstate(invalid="ignore", divide="ignore"):
            peak = np.max(np.abs(shapes), axis=0)
            to_unit = peak / np.max(np.abs(raw), axis=0)  # the unit shape over the shape as given
        default = float(shape_noise) * peak[None, :] * np.ones_like(shapes)
        stated = ~np.isnan(s_std) & has[None, :]
        sh_std = np.where(stated, s_std * to_unit[None, :], default)
        sh_std = np.where(has[None, :], sh_std, np.nan)
        n_stated = (int(np.sum(~np.isnan(f_std))), int(np.sum(stated.all(axis=0) & has)))
        return cls(f, shapes, has, float(freq_noise), float(shape_noise), rel, sh_std, n_stated)

    @property
    def n_modes(self) -> int:
        return int(self.frequencies_hz.shape[0])

    @property
    def n_shape_modes(self) -> int:
        """How many of the modes carry a measured shape."""
        return int(self.has_shape.sum())

    @property
    def n_frequency_residuals(self) -> int:
        """The first `n_modes` residuals are frequencies, the rest shape entries."""
        return self.n_modes

    def dof(self, n_params: int) -> int:
        """Degrees of freedom of chi^2 for a model with `n_params` fitted parameters: every
        frequency, every shape entry less one per shape (its scale is free), less the parameters."""
        return max(self.n_residuals - self.n_shape_modes - n_params, 1)

    @property
    def n_residuals(self) -> int:
        return self.n_modes + int(self.has_shape.sum()) * self.shapes.shape[0]

    def pair(self, model_hz: np.ndarray, model_shapes: np.ndarray) -> np.ndarray:
        """Model mode index for each measured mode (-1: none): `correlation.pair_modes`."""
        return self.pair_batch(model_hz[None], self.mac_batch(model_shapes[None]))[0]

    @cached_property
    def _shape_sel(self) -> tuple[np.ndarray, np.ndarray]:
        """The measured unit shapes with a shape (n_coord, n_sel) and their entries' std: what
        `residuals_paired` compares every model with, selected once."""
        sel = self.has_shape
        u_m = self.shapes[:, sel]
        sigma = (self.shape_noise * np.max(np.abs(u_m), axis=0) if self.shape_std is None
                 else self.shape_std[:, sel])
        return u_m, np.broadcast_to(sigma, u_m.shape)

    @cached_property
    def _scaled_shapes(self) -> tuple[np.ndarray, np.ndarray]:
        """The measured shapes with a shape as `correlation.mac` scales them, and their squared
        norms: computed once, not at every model's pairing."""
        a = pow2_scaled(np.nan_to_num(self.shapes[:, self.has_shape]))
        return a, np.sum(a * a, axis=-2)

    def mac_batch(self, model_shapes: np.ndarray) -> np.ndarray | None:
        """The MAC of each measured mode with each model mode for a batch of models (shapes at
        the measured coordinates (b, n_coord, k)): (b, m, k), NaN in the rows without a measured
        shape; None when no mode has one. What `pair_batch` pairs on (the shapes' part of
        `correlation.pair_modes`, the same bits)."""
        if not self.has_shape.any():
            return None
        mm = np.full((model_shapes.shape[0], self.n_modes, model_shapes.shape[2]), np.nan)
        mm[:, self.has_shape] = mac_scaled(*self._scaled_shapes, model_shapes)
        return mm

    def pair_batch(self, model_hz: np.ndarray, mm: np.ndarray | None) -> np.ndarray:
        """`pair` for a batch of models: frequencies (b, k) and their `mac_batch` -> (b, m).
        The MACs do not depend on the frequencies: a fit pairing again at a new scale passes
        the same `mm`."""
        return pair_index(self.frequencies_hz, model_hz, mm, self.has_shape)

    def residuals(self, model_hz: np.ndarray, model_shapes: np.ndarray, pairing: np.ndarray | None = None):
        """Weighted residual vector for one model (its frequencies (k,) and shapes at the
        measured coordinates (n_coord, k)); pairs afresh unless `pairing` is given.

        Returns (r, pairing). An unpaired measured mode contributes a large fixed residual
        (as if 30 % off in frequency and orthogonal in shape) so that no fit can gain by
        losing a mode."""
        idx = self.pair(model_hz, model_shapes) if pairing is None else pairing
        return self.residuals_paired(model_hz[None], model_shapes[None], idx)[0], idx

    def residuals_paired(self, model_hz: np.ndarray, model_shapes: np.ndarray, pairing: np.ndarray) -> np.ndarray:
        """`residuals` of a batch of models with one pairing held: frequencies (b, k), shapes at the
        measured coordinates (b, n_coord, k); returns r (b, n_residuals). `residuals` is this
        on a batch of one; the first-order screen's hot path (thousands of candidates a chunk,
        screening.py) calls it on whole batches."""
        idx = pairing
        # a model mode that is not finite (a failed solve, dropped.py) pairs with nothing: the
        # large fixed residual of a lost mode, so that no fit prefers a size its model cannot solve
        at = np.maximum(idx, 0)
        f_raw = model_hz[:, at]                                                     # (b, m)
        ok = (idx >= 0)[None, :] & np.isfinite(f_raw)
        sel = self.has_shape
        if sel.any():  # so does a model shape that is not finite or does not move the measured coordinates
            u_a = model_shapes[:, :, at[sel]]                                       # (b, n_coord, n_sel)
            norms = np.sqrt(np.add.reduce(u_a * u_a, axis=1))  # (b, n_sel): np.linalg.norm's own sum
            ok[:, sel] &= np.isfinite(norms) & (norms > 0)
        f = np.where(ok, f_raw, self.frequencies_hz * (1 + MAX_PAIR_FREQ))
        rel = self.freq_noise if self.freq_rel_std is None else self.freq_rel_std
        r_f = (f - self.frequencies_hz) / (self.frequencies_hz * rel)
        if not sel.any():
            return r_f
        with np.errstate(divide="ignore", invalid="ignore"):
            np.divide(u_a, norms[:, None, :], out=u_a)  # in place: u_a is the gather's own copy
        u_m, sigma = self._shape_sel
        # close modes as `residuals` treats them: only the (model, mode) pairs that have a
        # neighbour within reach go through `close_mode_shape` (none on most models)
        cols = np.flatnonzero(sel)
        j = at[cols]
        hz_j = model_hz[:, j]                                                       # (b, n_sel)
        # a mode at 0 Hz (a negative eigenvalue clipped: a model softened past stability, as a
        # reduced screen's largest sizes may be) has no neighbour within reach: its gap is inf,
        # or 0 / 0 = NaN beside another at 0 Hz, and neither is below the reach
        with np.errstate(divide="ignore", invalid="ignore"):
            gap = np.abs(model_hz[:, None, :] - hz_j[:, :, None]) / hz_j[:, :, None]   # (b, n_sel, k)
        near = gap < CLOSE_MODES_REACH * CLOSE_MODES_REL
        near[:, np.arange(len(cols)), j] = False
        for b, col in zip(*np.nonzero(near.any(axis=2) & ok[:, cols])):
            mixed = close_mode_shape(u_m[:, col], model_hz[b], model_shapes[b], j[col])
            if mixed is not None:
                u_a[b, :, col] = mixed
        ok_sel = ok[:, sel]
        if not ok_sel.all():
            u_a = np.where(ok_sel[:, None, :], u_a, 0.0)
        u_a *= np.where(np.add.reduce(u_a * u_m, axis=1, keepdims=True) < 0, -1.0, 1.0)
        # each model's block in `residuals`' order: mode by mode, the coordinates within (order F),
        # written in place: (u_a - u_m) / sigma                                   # (b, n_sel, n_coord)
        n_b, m = r_f.shape
        out = np.empty((n_b, m + u_m.size))
        out[:, :m] = r_f
        shape_r = out[:, m:].reshape(n_b, u_m.shape[1], u_m.shape[0])  # a view of out's tail
        np.subtract(u_a.transpose(0, 2, 1), u_m.T, out=shape_r)
        np.divide(shape_r, sigma.T, out=shape_r)
        return out
