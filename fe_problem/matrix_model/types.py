"""`MatrixModel`: a structure given as its matrices, K(theta) = sum_i theta_i K_i and
M(mu) = sum_j mu_j M_j (the manifest `femu.matrix-model/1`, docs/matrix-model.md).

A term is one matrix with its multiplier: an updating parameter where it has bounds, fixed at
its `initial` value otherwise. The matrices are held as symmetric CSR matrices on all the
model's DOFs (an exported model has its supported DOFs removed already: every row is free).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

#: The format tag of a matrix-model manifest.
MATRIX_FORMAT = "femu.matrix-model/1"

#: Which matrix a term belongs to.
FAMILIES = ("stiffness", "mass")


class MatrixModelError(ValueError):
    """A matrix-model manifest or matrix that breaks the format; the message names the
    manifest, the term and the problem."""


@dataclass(frozen=True, eq=False)
class MatrixTerm:
    """One matrix of a model and its multiplier.

    name: unique over the model's stiffness and mass terms; family: ``stiffness`` or ``mass``;
    matrix: symmetric (n, n) CSR in the model's units (N/m and kg for translations, N m/rad
    and kg m^2 for rotations, whatever the exporting program used); initial: the multiplier at
    the model's initial values (dimensionless); lower, upper: its bounds when the term is an
    updating parameter, else None; file, variable: where the matrix was read from (file
    absolute, None for a matrix made in memory), for writing the manifest back."""

    name: str
    family: str
    matrix: sp.csr_matrix
    initial: float = 1.0
    lower: float | None = None
    upper: float | None = None
    file: str | None = None
    variable: str | None = None

    @property
    def is_parameter(self) -> bool:
        """Whether the term's multiplier is an updating parameter (it has bounds)."""
        return self.lower is not None


@dataclass(frozen=True)
class MatrixParameter:
    """An updating parameter of a matrix model: the multiplier of one term (dimensionless).

    `kind` is ``"stiffness multiplier"`` or ``"mass multiplier"``; `label` is the term's name."""

    name: str
    family: str
    lower: float
    upper: float
    initial: float

    @property
    def kind(self) -> str:
        """``"stiffness multiplier"`` or ``"mass multiplier"``."""
        return f"{self.family} multiplier"

    @property
    def label(self) -> str:
        """The term's name."""
        return self.name

    @property
    def targets(self) -> tuple:
        """No elements: a matrix term is not made of the model's elements."""
        return ()


@dataclass(frozen=True, eq=False)
class MatrixModel:
    """A model given as matrices (docs/matrix-model.md).

    name: free text; dofs: the DOF labels, one per row: the integers 1..n when the manifest
    gave a count, else (node, direction) pairs; stiffness, mass: the terms (MatrixTerm);
    meta: kept as read; source: the manifest's path ("" in memory)."""

    name: str
    dofs: tuple
    stiffness: tuple[MatrixTerm, ...]
    mass: tuple[MatrixTerm, ...]
    meta: dict = field(default_factory=dict)
    source: str = ""
    description: str = ""

    @property
    def n_dof(self) -> int:
        """Number of DOFs (rows of every matrix)."""
        return len(self.dofs)

    @property
    def labelled(self) -> bool:
        """Whether the DOFs are (node, direction) labels (False: row numbers 1..n)."""
        return bool(self.dofs) and isinstance(self.dofs[0], tuple)

    @property
    def terms(self) -> tuple[MatrixTerm, ...]:
        """The stiffness terms, then the mass terms."""
        return self.stiffness + self.mass

    @property
    def parameters(self) -> tuple[MatrixParameter, ...]:
        """The updating parameters: the terms with bounds, stiffness ones first, in manifest order."""
        return tuple(MatrixParameter(t.name, t.family, t.lower, t.upper, t.initial)
                     for t in self.terms if t.is_parameter)

    def term(self, name: str) -> MatrixTerm:
        """The term named `name` (KeyError naming the ones there are)."""
        for t in self.terms:
            if t.name == name:
                return t
        raise KeyError(f"model {self.name!r} has no term {name!r} (terms: {', '.join(t.name for t in self.terms)})")

    def total(self, family: str, values: dict | None = None) -> sp.csr_matrix:
        """K or M (`family`) at the initial multipliers, or with `values` {term name: multiplier}."""
        values = values or {}
        terms = self.stiffness if family == "stiffness" else self.mass
        out = sp.csr_matrix((self.n_dof, self.n_dof))
        for t in terms:
            out = out + values.get(t.name, t.initial) * t.matrix
        return out.tocsr()

    def with_initials(self, values: dict) -> "MatrixModel":
        """A copy whose terms named in `values` {name: multiplier} have that `initial` (the
        updated model; the matrices are shared, not copied)."""
        unknown = set(values) - {t.name for t in self.terms}
        if unknown:
            raise KeyError(f"model {self.name!r} has no term(s) {sorted(unknown)}")

        def one(t: MatrixTerm) -> MatrixTerm:
            return dataclasses.replace(t, initial=float(values[t.name])) if t.name in values else t
        return dataclasses.replace(self, stiffness=tuple(map(one, self.stiffness)), mass=tuple(map(one, self.mass)))

    def row_of(self, label) -> int | None:
        """The 0-based row of a DOF label (an int 1..n, or a (node, direction) pair), None if the
        model has no such DOF."""
        if self.labelled:
            if not (isinstance(label, (tuple, list)) and len(label) == 2):
                return None
            return self._label_rows.get((label[0], label[1]))
        if isinstance(label, (bool, np.bool_)) or not isinstance(label, (int, np.integer)):
            return None
        return int(label) - 1 if 1 <= label <= self.n_dof else None

    @property
    def _label_rows(self) -> dict:
        rows = self.__dict__.get("_rows")
        if rows is None:
            rows = {d: i for i, d in enumerate(self.dofs)}
            object.__setattr__(self, "_rows", rows)
        return rows


__all__ = ["FAMILIES", "MATRIX_FORMAT", "MatrixModel", "MatrixModelError", "MatrixParameter", "MatrixTerm"]
