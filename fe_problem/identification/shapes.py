"""Residues of the chosen poles by a windowed least-squares frequency-domain fit, and real modes.

Why not one global LSFD: sdypy-EMA's LSFD models everything outside the band by a lower and
an upper residual (a constant and an omega^2 term for accelerance). A mode that lies just
above the band bends the FRFs near the band's edge more than an omega^2 term can follow, and
the residues of the top in-band mode are biased (MAC 0.99 against the truth on noise-free
FRFs of the H-frame with the next mode 5 % above the band). Here each mode's residues are fitted
on a window around its own peak, with the poles within twice the window in the model and a
local complex residual that is linear in frequency: other modes, in the band or out of it, are
smooth across one window. The stabilisation chart uses the same fit at every order.
"""

from __future__ import annotations

import numpy as np

#: Half-width of a mode's window, in half-power half-widths (zeta f), and the fewest lines on each side
WINDOW_HALF_WIDTHS = 5.0
MIN_WINDOW_LINES = 10


def _basis(omega: np.ndarray, poles: np.ndarray, form: str) -> np.ndarray:
    """Complex columns (n_lines, 2 n_poles): the real and imaginary part of each residue A in
    A / (i w - p) + conj(A) / (i w - conj(p)), times the form's factor (-w^2, i w or 1)."""
    iw = 1j * omega[:, None]
    a, b = 1 / (iw - poles[None, :]), 1 / (iw - poles.conj()[None, :])
    factor = {"accelerance": -(omega**2), "mobility": 1j * omega, "receptance": np.ones_like(omega)}[form][:, None]
    return np.concatenate([factor * (a + b), factor * 1j * (a - b)], axis=1)


def windowed_residues(poles: np.ndarray, frequency_hz: np.ndarray, frf: np.ndarray, form: str,
                      with_std: bool = False):
    """Complex residues (n_channels, n_poles) in receptance form (r = phi_j phi_ref / (2 i w_d) for a
    proportionally damped mode with mass-normalised phi), each from its own window. With
    `with_std`, also each residue's standard deviation (n_channels, n_poles): the least-squares
    fit's covariance s^2 (M^T M)^-1 with s^2 the channel's residual variance over the window
    (its degrees of freedom), sqrt of the mean of the real and imaginary parts' variances."""
    omega = 2 * np.pi * np.asarray(frequency_hz, float)
    df = frequency_hz[1] - frequency_hz[0]
    f0, zeta = np.abs(poles) / (2 * np.pi), -poles.real / np.abs(poles)
    out = np.empty((frf.shape[0], poles.size), complex)
    std = np.full((frf.shape[0], poles.size), np.nan)
    for r in range(poles.size):  # one small least-squares problem per mode, all channels at once
        half = max(WINDOW_HALF_WIDTHS * zeta[r] * f0[r], MIN_WINDOW_LINES * df)
        w = np.abs(frequency_hz - f0[r]) <= half
        near = np.flatnonzero(np.abs(f0 - f0[r]) <= 2 * half)   # poles farther away are smooth here
        om = omega[w]
        local = (om - om.mean()) / max(om.std(), 1e-12)
        k = near.size
        cols = np.concatenate([_basis(om, poles[near], form), np.ones((om.size, 1)), local[:, None]], axis=1)
        # real unknowns: [Re A, Im A] per pole, then complex residual coefficients (2 real each)
        real_cols = np.concatenate([cols[:, : 2 * k], cols[:, 2 * k:], 1j * cols[:, 2 * k:]], axis=1)
        m = np.concatenate([real_cols.real, real_cols.imag])
        y = np.concatenate([frf[:, w].real, frf[:, w].imag], axis=1).T
        scale = np.maximum(np.linalg.norm(m, axis=0), 1e-300)
        xs = np.linalg.lstsq(m / scale, y, rcond=None)[0]
        x = xs / scale[:, None]
        i = int(np.flatnonzero(near == r)[0])
        out[:, r] = x[i] + 1j * x[k + i]
        dof = m.shape[0] - m.shape[1]
        if with_std and dof > 0:
            s2 = np.sum((y - (m / scale) @ xs) ** 2, axis=0) / dof                 # (n_channels,)
            g = np.diag(np.linalg.pinv((m / scale).T @ (m / scale))) / scale**2     # (n_unknowns,)
            std[:, r] = np.sqrt(s2 * (g[i] + g[k + i]) / 2)
    return (out, std) if with_std else out


def normal_shapes(residues: np.ndarray, modal_poles: np.ndarray, driving: int | None) -> tuple[np.ndarray, str]:
    """Real normal modes (n_channels, n_modes) from complex residues (receptance form). Mass-
    normalised through the driving point (channel index `driving`) when given, else unit norm;
    each signed so that its largest-magnitude entry is positive. Returns (shapes, scaling)."""
    from sdypy.EMA import normal_modes

    real = np.asarray(normal_modes.complex_to_normal_mode(residues)).reshape(residues.shape)  # unit norm
    scaling = "unit norm"
    if driving is not None:
        constant = (2j * modal_poles.imag[None, :] * residues).real            # phi_j phi_ref
        along = np.abs(np.sum(constant * real, axis=0))                         # |phi_ref| |phi|
        phi_ref = np.sqrt(np.abs(constant[driving]))
        ok = phi_ref > 0
        real = real * np.where(ok, along / np.where(ok, phi_ref, 1.0), 1.0)
        scaling = "mass-normalised through the driving point"
    big = np.take_along_axis(real, np.abs(real).argmax(0)[None, :], 0)
    return real * np.where(big < 0, -1.0, 1.0), scaling
