"""Modal analysis: natural frequencies (Hz) and mass-normalised mode shapes.

There is one modal solver in the project, `AffineModel.eigen` (batched, in
solver.py); `modal_analysis` is the friendly front door for a single model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import FrameModel
from .any_model import load_any_model
from .assembly import AffineModel
from .matrix_model import MatrixModel, MatrixSystem
from .parameters import Parameter


@dataclass(frozen=True)
class ModalResult:
    """Elastic modes of a model.

    frequencies_hz: (n_modes,) ascending; shapes: (n_dof, n_modes) on the nodal DOFs, mass-
    normalised (phi^T M phi = I over all DOFs), zero at supported DOFs; dofs: one
    (node id, direction) per row of `shapes` (for a matrix model, its DOF labels: the row
    numbers 1..n where it gave a count); n_rigid: zero-energy modes that were dropped;
    mechanism: None, or which of those are mechanism motions rather than rigid-body motions;
    path: the solver path that computed them ("dense" or "sparse", `AffineModel.path`).
    """

    frequencies_hz: np.ndarray
    shapes: np.ndarray
    dofs: tuple[tuple[int, str], ...]
    n_rigid: int
    mechanism: str | None = None
    path: str = "dense"

    @property
    def eigenvalues(self) -> np.ndarray:
        """omega^2 in (rad/s)^2."""
        return (2.0 * np.pi * self.frequencies_hz) ** 2

    def at(self, dofs) -> np.ndarray:
        """Shape rows at the listed (node, direction) DOFs, (len(dofs), n_modes)."""
        index = {d: i for i, d in enumerate(self.dofs)}
        keys = [tuple(d) if isinstance(d, (list, tuple)) else d for d in dofs]
        missing = [d for d in keys if d not in index]
        if missing:
            raise KeyError(f"no such DOF(s) in this model: {missing}")
        return self.shapes[[index[d] for d in keys]]


def frequencies_hz(eigenvalues: np.ndarray) -> np.ndarray:
    """omega^2 (rad/s)^2 to Hz; tiny negative round-off is clipped to zero."""
    return np.sqrt(np.clip(eigenvalues, 0.0, None)) / (2.0 * np.pi)


def modal_analysis(model: FrameModel | MatrixModel | str, n_modes: int = 8, parameters: tuple[Parameter, ...] = (),
                   theta=None, at_most: bool = False, solver: str = "auto") -> ModalResult:
    """The `n_modes` lowest elastic modes of `model` (a FrameModel, a MatrixModel, a shipped model
    name, a model file or a matrix manifest path; a matrix model at its terms' `initial` values,
    or with `parameters` None or its parameter names and `theta` their multipliers).

    With `parameters` and `theta`, the modes of the model updated to those values. A model
    with fewer elastic modes raises ValueError, unless `at_most`: then all it has are returned
    (compare ``len(result.frequencies_hz)`` with `n_modes`). `solver`: ``"auto"``, ``"dense"`` or
    ``"sparse"`` (`AffineModel`).
    """
    model = load_any_model(model)
    if n_modes < 1:
        raise ValueError(f"n_modes must be >= 1, got {n_modes}")
    if isinstance(model, MatrixModel):
        system = MatrixSystem(model, tuple(parameters) if theta is not None else (), solver=solver)
    else:
        system = AffineModel(model, tuple(parameters), solver=solver)
    theta = system.x0 if theta is None else np.asarray(theta, dtype=float)
    if theta.shape != (system.n_params,):
        raise ValueError(f"theta must have shape ({system.n_params},), got {theta.shape}")
    if system.n_elastic == 0:
        raise ValueError(f"{model.source or model.name}: the model has no elastic mode: every motion strains "
                         "nothing (check its stiffness values and connections)")
    if at_most:
        n_modes = min(n_modes, system.n_elastic)
    lam, phi = system.eigen(theta[None, :], n_modes, vectors=True)
    return ModalResult(frequencies_hz(lam[0]), system.expand(phi[0]), model.dofs, system.n_rigid, system.mechanism,
                       system.path)
