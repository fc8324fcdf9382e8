"""What every candidate of one diagnosis of a model given as matrices shares (`MatrixSetting`).

One `MatrixSystem` holds the model and every change a candidate can make, each a column of
its parameter vector x (the project's one sparse solver, sparse.py: one CSR pattern, values
c0 + G x, DOFs without mass solved exactly):

- every term of the model, its multiplier (the calibrated model: each term at its `initial`);
- a unit mass e_d e_d^T (1 in the model's mass unit) and a unit spring to ground e_d e_d^T
  (1 in its stiffness unit) at every measured DOF d, each at 0 in the calibrated model.

A candidate changes one column (`forward`); the sparse class over terms changes several
(`solve`). The first-order terms of each change are the columns' matrices themselves: dK/da =
K_i, dM/da = e_d e_d^T, dK/da = k_ref e_d e_d^T (`MatrixSystem.eigen_sensitivities`).
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import scipy.sparse as sp

from ..dofs import SPATIAL
from ..matrix_model import MatrixModel, MatrixParameter, MatrixSystem, MatrixTerm
from ..modal import frequencies_hz

#: The prefixes of the unit terms added at the measured DOFs (never a user's term name: a
#: manifest's names are free text, so they are checked against these).
MASS_PREFIX, SPRING_PREFIX = "+mass@", "+spring@"
#: The translations among the direction labels (a mass at one of them is a mass in kg).
TRANSLATIONS = tuple(d for d in SPATIAL if not d.startswith("r"))


def dof_text(label) -> str:
    """A DOF label as text: '3x' for (node 3, x), 'DOF 5' for row number 5."""
    return f"{label[0]}{label[1]}" if isinstance(label, tuple) else f"DOF {label}"


def dof_location(label) -> dict:
    """A DOF as a candidate's location: {"node", "direction"} or {"dof": row number}."""
    return {"node": label[0], "direction": label[1]} if isinstance(label, tuple) else {"dof": int(label)}


@dataclass(frozen=True, eq=False)
class MatrixSetting:
    """The model, the measured DOFs (`coords`, as the data give them), how many model modes to
    compute, and the one system every candidate is solved with (see the module docstring)."""

    model: MatrixModel
    coords: tuple
    n_modes: int
    system: MatrixSystem
    rows: np.ndarray        # the measured DOFs' rows
    columns: dict           # term name or unit term name -> column of x

    @classmethod
    def of(cls, model: MatrixModel, coords, n_modes: int) -> "MatrixSetting":
        """The setting of `model` measured at `coords`, computing `n_modes` model modes (capped at
        the model's elastic modes)."""
        coords = tuple(tuple(d) if isinstance(d, (list, tuple)) else int(d) for d in coords)
        rows = np.array([model.row_of(d) for d in coords], dtype=int)
        n = model.n_dof
        clash = [t.name for t in model.terms if t.name.startswith((MASS_PREFIX, SPRING_PREFIX))]
        if clash:
            raise ValueError(f"{model.source or model.name}: term {clash[0]!r}: a name starting with "
                             f"{MASS_PREFIX!r} or {SPRING_PREFIX!r} is kept for the diagnosis's own terms")
        extra_m, extra_k = [], []
        for d, r in zip(coords, rows):
            unit = sp.csr_matrix(([1.0], ([r], [r])), shape=(n, n))
            extra_m.append(MatrixTerm(f"{MASS_PREFIX}{r}", "mass", unit, 0.0))
            extra_k.append(MatrixTerm(f"{SPRING_PREFIX}{r}", "stiffness", unit, 0.0))
        augmented = dataclasses.replace(model, stiffness=model.stiffness + tuple(extra_k),
                                        mass=model.mass + tuple(extra_m))
        params = tuple(MatrixParameter(t.name, t.family, 0.0, np.inf, t.initial) for t in augmented.terms)
        system = MatrixSystem(augmented, params)
        columns = {p.name: k for k, p in enumerate(params)}
        return cls(model, coords, min(n_modes, system.n_elastic), system, rows, columns)

    @property
    def x0(self) -> np.ndarray:
        """The calibrated model's point: every term at its `initial`, no added mass or spring."""
        return self.system.x0

    def solve(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Frequencies (b, k) in Hz and shapes at the measured DOFs (b, n_coord, k) for points x (b, p)."""
        lam, phi = self.system.eigen(np.atleast_2d(x), self.n_modes, vectors=True, rows=self.rows)
        return frequencies_hz(lam), phi

    def forward(self, column: int, values) -> tuple[np.ndarray, np.ndarray]:
        """`solve` with column `column` of x0 set to each of `values` (b,)."""
        values = np.asarray(values, dtype=float)
        x = np.repeat(self.x0[None, :], len(values), axis=0)
        x[:, column] = values
        return self.solve(x)

    @functools.cached_property
    def modes0(self) -> tuple[np.ndarray, np.ndarray]:
        """The calibrated model's modes, solved once: (1, k) Hz, (1, n_coord, k)."""
        return self.solve(self.x0[None, :])

    @functools.cached_property
    def screen_setting(self) -> SimpleNamespace:
        """What the first-order screen (screening.screen_all) asks of a setting: the model's own
        system at its initial values (no parameter: its k0, m0 are K and M, as a frame's
        `Setting.system`), with the DOF map the screen's gathers use (every DOF free), and the
        baselines it keeps."""
        system = MatrixSystem(self.model, ())
        system.dofmap = SimpleNamespace(n_total=self.model.n_dof, free=np.arange(self.model.n_dof))
        return SimpleNamespace(system=system, baselines={})

    @functools.cached_property
    def mass_diagonal(self) -> np.ndarray:
        """The diagonal of M at the initial values (one entry per DOF, the model's mass units)."""
        return self.model.total("mass").diagonal()

    @functools.cached_property
    def total_mass(self) -> float:
        """The structure's mass as the matrices give it: the largest sum of M's diagonal over the
        DOFs of one translation (labelled DOFs), or over every DOF (DOFs given by a count)."""
        diag = self.mass_diagonal
        if not self.model.labelled:
            return float(diag.sum())
        by = [sum(m for (_, d), m in zip(self.model.dofs, diag) if d == t) for t in TRANSLATIONS]
        return float(max(max(by), 0.0)) or float(diag.sum())

    @functools.cached_property
    def reference_stiffness(self) -> float:
        """k_ref = total mass x (2 pi f_1)^2 of the model at its initial values: a spring to
        ground's scale, as a frame's `boundary_stiffness` (N/m in SI units)."""
        hz = self.modes0[0][0]
        return float(self.total_mass * (2.0 * np.pi * hz[0]) ** 2)

    def with_scale(self, model: MatrixModel, s: float) -> MatrixModel:
        """`model` with every stiffness term's multiplier times s (the calibrated global scale)."""
        return dataclasses.replace(model, stiffness=tuple(dataclasses.replace(t, initial=s * t.initial)
                                                          for t in model.stiffness))


__all__ = ["MASS_PREFIX", "SPRING_PREFIX", "MatrixSetting", "dof_location", "dof_text"]
