"""Element formulations behind one interface (base.py), in a registry: the planar
Euler-Bernoulli (optionally cracked) and Timoshenko beams (frame2d.py, kernels in
beam2d.py), and modulus profiles along an element.

Model-level helpers here work on any mix of registered formulations: `element_matrices`
(stiffness and mass of every element), `profile_stiffness`, `deformed_frame` (drawing).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from . import frame2d  # noqa: F401  (registers the planar formulations)
from . import frame3d  # noqa: F401  (registers the space frame formulations)
from .base import ElementFormulation, formulation, formulations, register

if TYPE_CHECKING:
    from ..model import Element, FrameModel

#: Names of the formulations registered for planar models (the values of an element's
#: ``formulation``; `formulations(layout)` lists those of another layout).
FORMULATIONS = formulations()

#: Modulus profiles along an element: w(xi) piecewise linear through these values at xi = 0, 1/2, 1.
PROFILES = {"uniform": (1.0, 1.0, 1.0), "toward_i": (1.0, 0.5, 0.0), "toward_j": (0.0, 0.5, 1.0),
            "middle": (0.0, 1.0, 0.0)}


def _groups(model: FrameModel):
    """(formulation, positions in model.elements, elements) for each formulation used."""
    for name in dict.fromkeys(e.formulation for e in model.elements):
        rows = [k for k, e in enumerate(model.elements) if e.formulation == name]
        yield formulation(name, model.layout), rows, [model.elements[k] for k in rows]


def element_matrices(model: FrameModel) -> tuple[np.ndarray, np.ndarray]:
    """Global-axis stiffness per unit modulus (E = 1) and mass per unit density of every
    element, both (n_el, k, k) on the element's end DOFs (k = 2 DOFs per node)."""
    k_dof = 2 * model.layout.per_node
    k = np.zeros((len(model.elements), k_dof, k_dof))
    m = np.zeros_like(k)
    for form, rows, els in _groups(model):
        k[rows] = form.stiffness(model, els)
        m[rows] = form.mass(model, els)
    return k, m


def profile_stiffness(model: FrameModel, element: Element, profile: str) -> np.ndarray:
    """Global-axis stiffness (1, k, k) per unit modulus of `element` with a modulus profile
    (a name in `PROFILES`); ValueError if its formulation has none."""
    form = formulation(element.formulation, model.layout)
    if not form.supports_profile:
        raise ValueError(f"element {element.id}: formulation {form.name!r} has no modulus profiles")
    return form.profile_stiffness(model, element, PROFILES[profile])


def deformed_frame(model: FrameModel, u: np.ndarray, scale: float, n_points: int = 25) -> np.ndarray:
    """Element curves (n_elements, n_points, layout.dimension) in metres of the frame displaced
    by scale * u (a drawing of a space model projects them: femu/reports).

    u: one value per nodal DOF in `model.dofs` order. Along an element the displacement is the
    formulation's own interpolation of its end values (for the planar beams: axial linear,
    transverse the Hermite cubic of the end displacements and rotations); an element with a
    released end or a crack is drawn straight between its displaced nodes, since its ends' own
    rotations are not nodal DOFs."""
    per = model.layout.per_node
    U = np.asarray(u, dtype=float).reshape(len(model.nodes), per)
    index = {n.id: k for k, n in enumerate(model.nodes)}
    xy = np.asarray(model.coordinates)
    xi = np.linspace(0.0, 1.0, n_points)
    out = np.empty((len(model.elements), n_points, model.layout.dimension))
    for form, rows, els in _groups(model):
        i = np.array([index[e.node_i] for e in els])
        j = np.array([index[e.node_j] for e in els])
        base = xy[i][:, None, :] + xi[None, :, None] * (xy[j] - xy[i])[:, None, :]
        ends = np.concatenate([U[i], U[j]], axis=1)
        out[rows] = base + scale * form.displaced(model, els, ends, xi)
    return out


__all__ = ["ElementFormulation", "FORMULATIONS", "PROFILES", "deformed_frame", "element_matrices", "formulation",
           "formulations", "profile_stiffness", "register"]
