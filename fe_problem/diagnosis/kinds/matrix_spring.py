"""``dof_spring`` of a model given as matrices, at a measured DOF: a spring to ground of stiffness
a k_ref on the diagonal of K there, k_ref = total mass x (2 pi f_1)^2 (`MatrixSetting.
reference_stiffness`, a frame's `boundary_stiffness` scale), a in [1e-4, 100] (a soft support, a
tie the model lacks). Linear in one column of the diagnosis's system (matrix_setting.py): its
first-order term is k_ref e_d e_d^T."""

from __future__ import annotations

import dataclasses
from typing import Iterator

import numpy as np

from ...matrix_model import MatrixTerm
from ..local import Term
from ..matrix_setting import SPRING_PREFIX, MatrixSetting, dof_location, dof_text
from ..setting import Candidate
from .boundary_stiffness import BOUNDARY_GRID
from .matrix_mass import new_name, unit
from .spec import KindSpec

UPPER = 100.0


def dof_spring(st: MatrixSetting) -> Iterator[Candidate]:
    """A spring to ground of stiffness a k_ref at each measured DOF."""
    k_ref = st.reference_stiffness
    for label, row in zip(st.coords, st.rows):
        col = st.columns[f"{SPRING_PREFIX}{row}"]

        def forward(a, col=col):
            return st.forward(col, k_ref * np.asarray(a, dtype=float))

        def estimate(a, s, label=label):
            return {"stiffness": s * k_ref * a, "stiffness_ratio": a, "dof": dof_text(label)}

        def extend(a, label=label, row=row):
            name = new_name(st.model, f"diagnosis-spring-{dof_text(label).replace(' ', '')}")
            term = MatrixTerm(name, "stiffness", k_ref * a * unit(st.model.n_dof, row), 1.0)
            return dataclasses.replace(st.model, stiffness=st.model.stiffness + (term,))

        yield Candidate("dof_spring", dof_location(label), UPPER, BOUNDARY_GRID, forward, estimate, extend,
                        step=1e-3, meta={"row": int(row)},
                        term=lambda row=row: Term(np.array([row]), np.full((1, 1), k_ref), np.zeros((1, 1))))


SPEC = KindSpec("dof_spring", "local", ("node", "direction"), dof_spring,
                doc="a spring to ground at a measured DOF of a matrix model")
