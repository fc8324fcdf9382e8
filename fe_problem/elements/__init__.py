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
from . import lumped  # noqa: F401  (registers their lumped-mass variants, "<name>-lumped")
from .base import ElementFormulation, formulation, formulations, register

if TYPE_CHECKING:
    from ..model import Element, FrameModel

#: Names of the formulations registered for planar models (the values of an element's
#: ``formulation``; `formulations(layout)` lists those of another layout).
FORMULATIONS = formulations()

#: Modulus profiles along an element: w(xi) piecewise linear through these values at xi = 0, 1/2, 1.
PROFILES = {"uniform": (1.0, 1.0, 1.0), "toward_i": (1.0, 0.5, 0.0), "toward_j": (0.0, 0.5, 1.0),
            "middle": (0.0, 1.0, 0.0)}


def _groups(model: FrameModel, rows=None):
    """(formulation, positions, elements) for each formulation used, in first-seen order, among
    the elements at positions `rows` of model.elements (default: all); positions within `rows`."""
    elements = model.elements if rows is None else [model.elements[r] for r in rows]
    for name in dict.fromkeys(e.formulation for e in elements):
        at = [j for j, e in enumerate(elements) if e.formulation == name]
        yield formulation(name, model.layout), at, [elements[j] for j in at]


#: The element matrices of the last few models built, most recent first: (nodes, elements,
#: sections, materials, layout, k, m), the model's own tables (held, so compared by identity).
#: A diagnosis builds hundreds of systems of one model, or of copies that differ in a few
#: elements (a released end, a modulus) or only outside the elements (a spring): an element
#: object kept on the same nodes, sections and materials has the same matrices, taken from here.
_KEPT: list[tuple] = []
_KEEP = 4
#: The most memory the kept matrices take (bytes, all entries): a huge model is not held.
_KEEP_BYTES = 64 * 2**20


def _unchanged(entry: tuple, model: FrameModel) -> bool:
    """Whether the sections and materials dicts of a kept entry (the same objects as `model`'s)
    still hold the same values: a dict is mutable, a frozen model's too."""
    sections, materials = entry[7]
    return (len(sections) == len(model.sections) and len(materials) == len(model.materials)
            and all(model.sections.get(k) is v for k, v in sections)
            and all(model.materials.get(k) is v for k, v in materials))


def element_blocks(model: FrameModel, rows) -> tuple[np.ndarray, np.ndarray]:
    """Global-axis stiffness per unit modulus (E = 1) and mass per unit density (e, k, k) of the
    elements at positions `rows` of model.elements, computed (nothing kept): one call per
    formulation, in first-seen order. The one place element matrices are computed from their
    formulations (`element_matrices` of all or of the elements not kept; an edited system's)."""
    k_dof = 2 * model.layout.per_node
    k, m = np.zeros((len(rows), k_dof, k_dof)), np.zeros((len(rows), k_dof, k_dof))
    for form, at, els in _groups(model, rows):
        k[at], m[at] = form.stiffness(model, els), form.mass(model, els)
    return k, m


def element_matrices(model: FrameModel) -> tuple[np.ndarray, np.ndarray]:
    """Global-axis stiffness per unit modulus (E = 1) and mass per unit density of every
    element, both (n_el, k, k) on the element's end DOFs (k = 2 DOFs per node). Read-only.

    The elements a recent model (`_KEPT`) holds as the same objects, on the same nodes,
    sections and materials (the same tables), are copied from its matrices, and only the
    others computed: each element's matrices do not depend on which others are computed with
    it, bit for bit (tests/test_element_reuse.py)."""
    tables = (model.nodes, model.elements, model.sections, model.materials, model.layout)
    n_el = len(model.elements)
    todo = None
    for entry in _KEPT:
        if all(a is b for a, b in zip(entry[:5], tables)) and _unchanged(entry, model):
            return entry[5], entry[6]
    for entry in _KEPT:
        if all(a is b for a, b in zip(entry[:1] + entry[2:5], tables[:1] + tables[2:])) \
                and len(entry[1]) == n_el and _unchanged(entry, model):
            same = np.fromiter((a is b for a, b in zip(entry[1], model.elements)), bool, n_el)
            k, m = entry[5].copy(), entry[6].copy()
            todo = np.flatnonzero(~same)
            break
    if todo is None:
        k, m = element_blocks(model, range(n_el))
    elif todo.size:
        k[todo], m[todo] = element_blocks(model, todo)
    k.setflags(write=False), m.setflags(write=False)
    _KEPT.insert(0, tables + (k, m, (tuple(model.sections.items()), tuple(model.materials.items()))))
    del _KEPT[_KEEP:]
    total = 0
    for i, entry in enumerate(_KEPT):
        total += entry[5].nbytes + entry[6].nbytes
        if total > _KEEP_BYTES:
            del _KEPT[i:]
            break
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


__all__ = ["ElementFormulation", "FORMULATIONS", "PROFILES", "deformed_frame", "element_blocks", "element_matrices",
           "formulation", "formulations", "profile_stiffness", "register"]
