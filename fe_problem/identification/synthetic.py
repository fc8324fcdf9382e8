"""A synthetic modal test rig: FRFs of any model, as a roving-hammer or shaker test gives them.

Modal superposition of every elastic mode of the model (modes far above the band still
shape the FRFs through their stiffness residual), proportional (modal) viscous damping,
one fixed reference coordinate, FRFs at the measured coordinates, complex Gaussian noise.
Rigid-body modes are not simulated: a free-free test suspends the structure on soft
springs whose modes lie below the band, and their mass line is the constant that the
identification's lower residual absorbs.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .frf_io import DEFAULT_UNITS, FRFSet, write_csv, write_npz, write_uff58

#: How far above the band (a multiple of its top) modes are still superposed
MODES_UP_TO = 4.0


def _all_modes(model):
    """The model's elastic modes (ModalResult), as many as it has (public API only)."""
    from fe_problem import modal_analysis

    n = len(model.dofs)
    while n > 0:
        try:
            return modal_analysis(model, n)
        except ValueError:  # fewer elastic modes than DOFs: rigid-body modes or supports
            n -= 1
    raise ValueError(f"model {model.name!r} has no elastic mode")


def _damping(damping, n: int, rng) -> np.ndarray:
    """(n,) modal damping ratios from a number, a (low, high) range drawn uniformly, or an array."""
    d = np.asarray(damping, float)
    if d.ndim == 0:
        out = np.full(n, float(d))
    elif d.shape == (2,):
        out = rng.uniform(d[0], d[1], n)
    else:
        if d.shape[0] < n:
            raise ValueError(f"damping lists {d.shape[0]} ratios for {n} modes")
        out = d[:n].copy()
    if not np.all((out > 0) & (out < 1)):
        raise ValueError(f"modal damping ratios must lie in (0, 1), got {damping!r}")
    return out


def frf_matrix(frequency_hz: np.ndarray, modal_hz: np.ndarray, shapes_at: np.ndarray, shapes_ref: np.ndarray,
               damping: np.ndarray, form: str = "accelerance") -> np.ndarray:
    """FRFs (n_coordinates, n_lines) by modal superposition: sum_r phi_j phi_ref / (w_r^2 - w^2 + 2i z_r w_r w),
    times -w^2 (accelerance, m/s^2/N), i w (mobility) or 1 (receptance, m/N) for mass-normalised shapes."""
    w = 2 * np.pi * np.asarray(frequency_hz, float)[None, :]
    wr = 2 * np.pi * np.asarray(modal_hz, float)[:, None]
    receptance = (shapes_at * shapes_ref[None, :]) @ (1.0 / (wr**2 - w**2 + 2j * damping[:, None] * wr * w))
    factor = {"accelerance": -(w**2), "mobility": 1j * w, "receptance": np.ones_like(w)}[form]
    return receptance * factor


def synthetic_frf(model, band_hz=None, resolution_hz: float = 0.25, damping=0.015, noise: float = 0.0,
                  seed: int | None = 0, coordinates=None, reference=None, form: str = "accelerance",
                  model_name: str | None = None, path: str | Path | None = None,
                  test: str = "roving-hammer") -> FRFSet:
    """Simulate a single-reference modal test of `model` (FrameModel, shipped name or file).

    band_hz (lo, hi): the measured band (default 5 Hz to 1.1 x the 8th elastic frequency);
    resolution_hz: line spacing; damping: modal damping ratio, one number, a (low, high) range
    drawn per mode with `seed`, or one per mode; noise: std of complex Gaussian noise on each
    line, relative to the channel's RMS over the band (0.01 = 1 %); coordinates: measured
    (node, direction) (default the model's measured DOFs); reference: the fixed coordinate
    (default the model's excitation point); form: accelerance (m/s^2/N), mobility or receptance;
    model_name: the model the file names (a truth with a hidden effect names the nominal one).
    With `path`, also written: UFF 58 (`.uff`/`.unv`, as `test` "roving-hammer" or "shaker"),
    `.npz` or `.csv`. Returns the FRFSet.
    """
    from fe_problem import load_model

    model = load_model(model)
    rng = np.random.default_rng(seed)
    coordinates = tuple(tuple(c) for c in (model.measured_dofs if coordinates is None else coordinates))
    reference = tuple(model.excitation if reference is None else reference) if (reference or model.excitation) else None
    if not coordinates or reference is None:
        raise ValueError(f"model {model.name!r}: give coordinates= and reference= (the model lists none)")
    if form not in DEFAULT_UNITS:
        raise ValueError(f"form must be one of {sorted(DEFAULT_UNITS)}, got {form!r}")
    modes = _all_modes(model)
    if band_hz is None:
        band_hz = (5.0, 1.1 * modes.frequencies_hz[min(7, modes.frequencies_hz.size - 1)])
    lo, hi = float(band_hz[0]), float(band_hz[1])
    if not (0 <= lo < hi) or resolution_hz <= 0:
        raise ValueError(f"band_hz must be 0 <= lo < hi and resolution_hz > 0, got {band_hz}, {resolution_hz}")
    freq = lo + resolution_hz * np.arange(int(np.floor((hi - lo) / resolution_hz + 1e-9)) + 1)
    keep = modes.frequencies_hz <= MODES_UP_TO * hi
    keep[0] = True
    zeta = _damping(damping, int(keep.sum()), rng)
    h = frf_matrix(freq, modes.frequencies_hz[keep], modes.at(coordinates)[:, keep],
                   modes.at([reference])[0, keep], zeta, form)
    if noise > 0:
        rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=1, keepdims=True))
        h = h + noise * rms * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)) / np.sqrt(2)
    frfs = FRFSet(freq, h, coordinates, reference, form, DEFAULT_UNITS[form], model_name or model.name)
    if path is not None:
        suffix = Path(path).suffix.lower()
        if suffix == ".npz":
            write_npz(frfs, path)
        elif suffix == ".csv":
            write_csv(frfs, path)
        else:
            write_uff58(frfs, path, test=test)
    return frfs
