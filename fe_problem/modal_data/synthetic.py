"""Synthetic 'measured' modal data from any model, with noise and random shape scaling."""

from __future__ import annotations

import numpy as np

from ..any_model import load_any_model
from ..matrix_model import MatrixModel
from ..modal import modal_analysis
from ..model import FrameModel
from .types import ModalData


def synthetic_measurement(model: FrameModel | MatrixModel | str, n_modes: int = 8, dofs=None, freq_noise: float = 0.0,
                          shape_noise: float = 0.0, seed: int | None = 0, random_sign_scale: bool = True,
                          model_name: str | None = None, with_shapes: bool = True,
                          parameters=(), theta=None) -> ModalData:
    """Synthetic 'measured' data from any model (with or without extra effects).

    Frequencies get relative Gaussian noise (std `freq_noise`, e.g. 0.002 for 0.2 %); shape
    entries get Gaussian noise of std `shape_noise` times the largest |entry| of the mode at
    the measured DOFs (the convention of test rigs, and the one `diagnose` states its noise
    in: `shape_noise=0.02` here is `--shape-noise 0.02` there); each shape then gets a random
    sign and a log-uniform scale in [0.1, 10]. Modes are re-sorted by frequency after the
    noise. `model_name` is what the data says it belongs to (default: the model's name; a
    truth model with a hidden effect names the nominal model). A matrix model (MatrixModel or
    manifest path) needs `dofs` (its labels, or row numbers where it gave a count), takes
    `parameters` as term names and `theta` as their multipliers, and its data name the
    manifest's path by default.
    """
    model = load_any_model(model)
    rng = np.random.default_rng(seed)
    given = getattr(model, "measured_dofs", ()) if dofs is None else dofs
    dofs = tuple(tuple(d) if isinstance(d, (list, tuple)) else int(d) for d in given)
    if not dofs:
        raise ValueError(f"model {model.name!r} lists no measured DOFs: pass dofs=")
    res = modal_analysis(model, n_modes, parameters=parameters, theta=theta)
    freqs = res.frequencies_hz * (1.0 + freq_noise * rng.standard_normal(n_modes))
    shapes = res.at(dofs).copy()
    peak = np.abs(shapes).max(axis=0)
    shapes += shape_noise * peak * rng.standard_normal(shapes.shape)
    if random_sign_scale:
        shapes *= rng.choice([-1.0, 1.0], n_modes) * np.exp(rng.uniform(np.log(0.1), np.log(10.0), n_modes))
    order = np.argsort(freqs, kind="stable")
    if not with_shapes:
        shapes[:] = np.nan
    meta = {"source": "synthetic", "truth_model": model.name, "freq_noise": freq_noise,
            "shape_noise": shape_noise, "seed": seed}
    if model_name is None and isinstance(model, MatrixModel) and model.source:
        model_name = model.source  # a matrix model is found by its manifest's path
    return ModalData(model_name or model.name, dofs, freqs[order], shapes[:, order], meta)
