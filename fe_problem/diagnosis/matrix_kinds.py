"""The candidate kinds of a model given as matrices: what its matrices allow a diagnosis to name.

- ``term_loss`` / ``term_gain`` at a term (``{"term": name}``): one stiffness or mass term's
  multiplier times (1 - a), a in [0, 0.9], or times (1 + a), a in [0, 3] (a substructure, a
  material group, a floor that is softer or stiffer, lighter or heavier than its model). A term
  that is its family's only one is left out: its change is the global stiffness-to-mass scale
  every model is allowed already.
- ``dof_mass`` at a measured DOF (``{"node", "direction"}`` or ``{"dof": row}``): a mass of a
  (the model's mass unit, kg in SI) added on the diagonal of M there, a up to half the
  structure's mass (`MatrixSetting.total_mass`).
- ``dof_spring`` at a measured DOF: a spring to ground of stiffness a k_ref on the diagonal of K,
  k_ref = total mass x (2 pi f_1)^2 (a soft support, a tie the model lacks), a in [1e-4, 100].

Each is linear in a in one column of the setting's system (matrix_setting.py), so its
first-order term is that column's matrix: K_i (or M_i), e_d e_d^T, k_ref e_d e_d^T. A place is
only a measured DOF for the DOF kinds: the data localise a mass or a spring where they see it;
a change spread over unmeasured DOFs is a term's.
"""

from __future__ import annotations

import dataclasses
from typing import Iterator

import numpy as np
import scipy.sparse as sp

from ..matrix_model import MatrixModel, MatrixTerm
from .candidates import BOUNDARY_GRID, GAIN_GRID, LOSS_GRID, Candidate, _MASS_STEPS, _shared
from .matrix_setting import MASS_PREFIX, SPRING_PREFIX, MatrixSetting, dof_location, dof_text

#: Effect-size ranges (the frames' `stiffness_loss`, `stiffness_gain`, `boundary_stiffness`).
LOSS_UPPER, GAIN_UPPER, SPRING_UPPER = 0.9, 3.0, 100.0
#: The added mass's range, as a fraction of the structure's mass (a frame's `added_mass`).
MASS_UPPER_FRACTION = 0.5


def varied_terms(model: MatrixModel) -> list[MatrixTerm]:
    """The terms whose change is a candidate: every term, less a family's only term (its change is
    the global scale's) and a term whose multiplier is 0 (it is not in the model)."""
    out = []
    for family in (model.stiffness, model.mass):
        live = [t for t in family if t.initial != 0.0]
        out += live if len(live) > 1 else []
    return out


def term_change(st: MatrixSetting, side: str) -> Iterator[Candidate]:
    """``term_loss`` (side "loss") or ``term_gain`` (side "gain") of every varied term."""
    sign, upper, grid = (-1.0, LOSS_UPPER, LOSS_GRID) if side == "loss" else (1.0, GAIN_UPPER, GAIN_GRID)
    for t in varied_terms(st.model):
        col = st.columns[t.name]

        def forward(a, col=col, m0=t.initial):
            return st.forward(col, m0 * (1.0 + sign * np.asarray(a, dtype=float)))

        def estimate(a, s, t=t):
            ratio = 1.0 + sign * a
            scale = s if t.family == "stiffness" else 1.0
            return {"term": t.name, "family": t.family, "change_pct": 100.0 * sign * a, "ratio": ratio,
                    "multiplier": scale * t.initial * ratio}

        def extend(a, t=t):
            return st.model.with_initials({t.name: t.initial * (1.0 + sign * a)})

        yield Candidate(f"term_{side}", {"term": t.name}, upper, grid, forward, estimate, extend, step=0.01,
                        meta={"family": t.family})


def term_loss(st: MatrixSetting) -> Iterator[Candidate]:
    """A term's multiplier times (1 - a)."""
    return term_change(st, "loss")


def term_gain(st: MatrixSetting) -> Iterator[Candidate]:
    """A term's multiplier times (1 + a)."""
    return term_change(st, "gain")


def _unit(st: MatrixSetting, row: int) -> sp.csr_matrix:
    n = st.model.n_dof
    return sp.csr_matrix(([1.0], ([row], [row])), shape=(n, n))


def _new_name(model: MatrixModel, base: str) -> str:
    """`base`, or `base-2`, ... : a term name the model does not have."""
    names = {t.name for t in model.terms}
    name, k = base, 2
    while name in names:
        name, k = f"{base}-{k}", k + 1
    return name


def dof_mass(st: MatrixSetting) -> Iterator[Candidate]:
    """A mass of a (kg) at each measured DOF."""
    total = st.total_mass
    grid = _shared(np.concatenate([[0.0], total * _MASS_STEPS]))
    for label, row in zip(st.coords, st.rows):
        col = st.columns[f"{MASS_PREFIX}{row}"]
        own = float(st.mass_diagonal[row])

        def forward(a, col=col):
            return st.forward(col, a)

        def estimate(a, s, label=label, own=own):
            out = {"mass_kg": a, "dof": dof_text(label), "fraction_of_total": a / total}
            return {**out, "ratio_to_dof_mass": a / own} if own > 0 else out

        def extend(a, label=label, row=row):
            name = _new_name(st.model, f"diagnosis-mass-{dof_text(label).replace(' ', '')}")
            term = MatrixTerm(name, "mass", a * _unit(st, row), 1.0)
            return dataclasses.replace(st.model, mass=st.model.mass + (term,))

        yield Candidate("dof_mass", dof_location(label), MASS_UPPER_FRACTION * total, grid, forward, estimate,
                        extend, step=1e-3 * total, meta={"row": int(row)})


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
            name = _new_name(st.model, f"diagnosis-spring-{dof_text(label).replace(' ', '')}")
            term = MatrixTerm(name, "stiffness", k_ref * a * _unit(st, row), 1.0)
            return dataclasses.replace(st.model, stiffness=st.model.stiffness + (term,))

        yield Candidate("dof_spring", dof_location(label), SPRING_UPPER, BOUNDARY_GRID, forward, estimate, extend,
                        step=1e-3, meta={"row": int(row)})


#: The kinds by name (the frames' `CANDIDATE_KINDS` for a matrix model).
MATRIX_KINDS = {"term_loss": term_loss, "term_gain": term_gain, "dof_mass": dof_mass, "dof_spring": dof_spring}
#: Labelled variants of one class at its place (`evidence.label_variants`): a term's loss and gain
#: are the two sides of one class; a DOF's mass and spring one each.
VARIANTS = {"term_loss": 2, "term_gain": 2, "dof_mass": 1, "dof_spring": 1}


def matrix_candidates(st: MatrixSetting, kinds=None) -> list[Candidate]:
    """Every candidate of the kinds asked (default all), in kind order; ValueError naming an
    unknown kind."""
    kinds = list(MATRIX_KINDS) if kinds is None else list(kinds)
    unknown = [k for k in kinds if k not in MATRIX_KINDS]
    if unknown:
        raise ValueError(f"unknown candidate kind(s) for a model given as matrices: {', '.join(unknown)} "
                         f"(kinds: {', '.join(MATRIX_KINDS)})")
    return [c for k in kinds for c in MATRIX_KINDS[k](st)]


__all__ = ["MATRIX_KINDS", "VARIANTS", "dof_mass", "dof_spring", "matrix_candidates", "term_gain", "term_loss",
           "varied_terms"]
