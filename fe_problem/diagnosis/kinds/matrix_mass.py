"""``dof_mass`` of a model given as matrices, at a measured DOF (``{"node", "direction"}``, or
``{"dof": row}`` where the manifest counts its DOFs): a mass of a (the model's mass unit, kg in SI)
on the diagonal of M there, a up to half the structure's mass (`MatrixSetting.total_mass`). Linear
in one column of the diagnosis's system (matrix_setting.py): its first-order term is e_d e_d^T.
Only measured DOFs: the data localise a mass where they see it."""

from __future__ import annotations

import dataclasses
from typing import Iterator

import numpy as np
import scipy.sparse as sp

from ...matrix_model import MatrixModel, MatrixTerm
from ..bounds import MASS_OF_TOTAL, MASS_PER_TRIBUTARY
from ..local import Term
from ..matrix_setting import MASS_PREFIX, MatrixSetting, dof_location, dof_text
from ..setting import Candidate, shared_grid
from .spec import KindSpec

_MASS_STEPS = np.geomspace(1e-3, 0.5, 15)  # added mass / the structure's mass (a frame's added_mass)
UPPER_FRACTION = 0.5


def unit(n: int, row: int) -> sp.csr_matrix:
    """e_d e_d^T on n DOFs."""
    return sp.csr_matrix(([1.0], ([row], [row])), shape=(n, n))


def new_name(model: MatrixModel, base: str) -> str:
    """`base`, or `base-2`, ...: a term name the model does not have."""
    names = {t.name for t in model.terms}
    name, k = base, 2
    while name in names:
        name, k = f"{base}-{k}", k + 1
    return name


def dof_mass(st: MatrixSetting) -> Iterator[Candidate]:
    """A mass of a at each measured DOF."""
    total = st.total_mass
    grid = shared_grid(np.concatenate([[0.0], total * _MASS_STEPS]))
    for label, row in zip(st.coords, st.rows):
        col = st.columns[f"{MASS_PREFIX}{row}"]
        own = float(st.mass_diagonal[row])

        def forward(a, col=col):
            return st.forward(col, a)

        def estimate(a, s, label=label, own=own):
            out = {"mass_kg": a, "dof": dof_text(label), "fraction_of_total": a / total}
            return {**out, "ratio_to_dof_mass": a / own} if own > 0 else out

        def extend(a, label=label, row=row):
            name = new_name(st.model, f"diagnosis-mass-{dof_text(label).replace(' ', '')}")
            term = MatrixTerm(name, "mass", a * unit(st.model.n_dof, row), 1.0)
            return dataclasses.replace(st.model, mass=st.model.mass + (term,))

        yield Candidate("dof_mass", dof_location(label), UPPER_FRACTION * total, grid, forward, estimate, extend,
                        step=1e-3 * total, meta={"row": int(row)},
                        term=lambda row=row: Term(np.array([row]), np.zeros((1, 1)), np.ones((1, 1))))


def check(model, loc: dict, estimate: dict) -> str | None:
    """More than `MASS_OF_TOTAL` of the structure's mass, or `MASS_PER_TRIBUTARY` times the DOF's own."""
    if "mass_kg" not in estimate:
        return None
    if estimate["fraction_of_total"] > MASS_OF_TOTAL:
        return f"a mass of {estimate['mass_kg']:.4g} is more than {MASS_OF_TOTAL:.0%} of the structure's"
    if estimate.get("ratio_to_dof_mass", 0.0) > MASS_PER_TRIBUTARY:
        return (f"a mass of {estimate['mass_kg']:.4g} is {estimate['ratio_to_dof_mass']:.3g} times what DOF "
                f"{estimate['dof']} carries (more than {MASS_PER_TRIBUTARY:g}x)")
    return None


SPEC = KindSpec("dof_mass", "local", ("node", "direction"), dof_mass, check=check,
                doc="a mass at a measured DOF of a matrix model")
