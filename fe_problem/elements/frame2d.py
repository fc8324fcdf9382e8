"""The planar frame elements: Euler-Bernoulli (optionally cracked) and Timoshenko beams with
an axial bar, on the nodal DOFs x, y, rz of `PLANAR_FRAME`.

Per element end the local DOFs are (u, v, theta); the matrices come from beam2d.py.
Timoshenko's shear ratio phi = 12 (E / G) I / (kappa A L^2) does not depend on E
(E / G = 2(1 + nu), or the material's E / shear_modulus_pa: G scales with an updated E), so
its stiffness stays linear in E.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np

from ..dofs import PLANAR_FRAME
from . import beam2d
from .base import ElementFormulation, coordinates, register

if TYPE_CHECKING:
    from ..model import Element, FrameModel


@dataclass(frozen=True)
class Geometry:
    """Lengths (m), direction cosines and section properties of a group of elements, (n,) each."""

    length: np.ndarray
    cos: np.ndarray
    sin: np.ndarray
    area: np.ndarray
    inertia: np.ndarray
    kappa: np.ndarray
    e_over_g: np.ndarray

    @classmethod
    def of(cls, model: FrameModel, elements: Sequence[Element]) -> "Geometry":
        """The geometry of `elements` of `model` (each section's and material's values read once
        and gathered: the same numbers as read element by element)."""
        at, pos = coordinates(model), model._node_pos  # not model.node(): O(n) per lookup
        ends = np.array([(pos[e.node_i], pos[e.node_j]) for e in elements], dtype=int).reshape(-1, 2)
        xi, xj = at[ends[:, 0]], at[ends[:, 1]]
        d = xj - xi
        length = np.hypot(d[:, 0], d[:, 1])
        sec, s_at = _gather([e.section for e in elements])
        mat, m_at = _gather([e.material for e in elements])
        sections, materials = [model.sections[k] for k in sec], [model.materials[k] for k in mat]
        return cls(length, d[:, 0] / length, d[:, 1] / length,
                   np.array([s.area_m2 for s in sections])[s_at], np.array([s.inertia_m4 for s in sections])[s_at],
                   np.array([s.shear_coefficient for s in sections])[s_at],
                   np.array([_e_over_g(m) for m in materials])[m_at])

    def to_global(self, local: np.ndarray) -> np.ndarray:
        """Local-axis element matrices (n, 6, 6) to global axes."""
        return beam2d.to_global(local, beam2d.rotation(self.cos, self.sin))


def _gather(names: list) -> tuple[list, np.ndarray]:
    """The distinct names in first-seen order and where each of `names` is among them."""
    first = {k: None for k in names}
    where = {k: i for i, k in enumerate(first)}
    return list(first), np.array([where[k] for k in names], dtype=int)


def _e_over_g(material) -> float:
    """E / G of a material: 2 (1 + nu), or E / shear_modulus_pa when that is given."""
    if material.shear_modulus_pa is None:
        return 2.0 * (1.0 + material.poisson_ratio)
    return material.youngs_modulus_pa / material.shear_modulus_pa


class _PlanarBeam(ElementFormulation):
    layout = PLANAR_FRAME

    def _phi(self, g: Geometry) -> np.ndarray:
        return np.zeros_like(g.length)

    def _rotary(self, g: Geometry) -> np.ndarray:
        return np.zeros_like(g.length)

    def mass(self, model, elements):
        g = Geometry.of(model, elements)
        return g.to_global(beam2d.local_mass(g.length, g.area, self._rotary(g), self._phi(g)))

    def displaced(self, model, elements, ends, xi):
        g = Geometry.of(model, elements)
        smooth = np.array([e.release_i is None and e.release_j is None and e.crack_position is None
                           and e.weak_zone is None for e in elements], dtype=bool)
        return beam2d.interpolate(g.length, g.cos, g.sin, ends, smooth, xi)


class EulerBernoulli(_PlanarBeam):
    """Hermite-cubic bending with consistent mass and no rotary inertia. A crack (a rotational
    spring of ``crack_stiffness`` N m/rad at ``crack_position``, scaling with the element's
    modulus) and a weak zone (``weak_zone``: a stretch of reduced bending stiffness) are
    built into the element by the flexibility formulation; the mass stays the beam's."""

    name = "euler-bernoulli"
    supports_crack = True
    supports_profile = True
    supports_weak_zone = True

    def stiffness(self, model, elements):
        g = Geometry.of(model, elements)
        k = beam2d.local_stiffness(g.length, g.area, g.inertia, self._phi(g))
        special = np.array([e.crack_position is not None or e.weak_zone is not None for e in elements], dtype=bool)
        if special.any():
            k[special] = self._flexible(model, [e for e, x in zip(elements, special) if x], g, special)
        return g.to_global(k)

    def _flexible(self, model, els, g: Geometry, rows: np.ndarray) -> np.ndarray:
        """Local stiffness per unit modulus of elements with a crack and/or a weak zone, built by
        the flexibility formulation: the crack's compliance is c * E (it scales with E, see
        Element); the zone's (1/ratio - 1) / (E I) times its integral (beam2d.zone_flexibility)."""
        length, inertia = g.length[rows], g.inertia[rows]
        extra = np.zeros((len(els), 2, 2))
        for k, e in enumerate(els):
            if e.crack_position is not None:
                c = model.element_modulus_pa(e.id) / e.crack_stiffness
                b = np.array([-(1.0 - e.crack_position), e.crack_position])
                extra[k] += c * np.outer(b, b)
            if e.weak_zone is not None:
                s, t, r = e.weak_zone
                extra[k] += beam2d.zone_flexibility(length[k:k + 1], inertia[k:k + 1], np.array([s]),
                                                    np.array([t]), np.array([r]))[0]
        bend = beam2d.flexibility_bending_stiffness(length, inertia, extra)
        return bend + beam2d.local_stiffness(length, g.area[rows], np.zeros(len(els)), self._phi(g)[rows])

    def profile_stiffness(self, model, element, weights):
        if element.crack_position is not None or element.weak_zone is not None:
            raise ValueError(f"element {element.id}: a modulus profile needs an element without a crack or weak zone")
        g = Geometry.of(model, [element])
        return g.to_global(beam2d.weighted_stiffness(g.length, g.area, g.inertia, weights))


class Timoshenko(_PlanarBeam):
    """Shear-deformable bending with Przemieniecki's consistent mass and rotary inertia (the
    formulation of OpenSees' ElasticTimoshenkoBeam2d)."""

    name = "timoshenko"

    def _phi(self, g: Geometry) -> np.ndarray:
        # 12 (2 (1 + nu)) rounds as 24 (1 + nu) did: 2 x is exact
        return 12.0 * g.e_over_g * g.inertia / (g.kappa * g.area * g.length**2)

    def _rotary(self, g: Geometry) -> np.ndarray:
        return g.inertia

    def stiffness(self, model, elements):
        g = Geometry.of(model, elements)
        return g.to_global(beam2d.local_stiffness(g.length, g.area, g.inertia, self._phi(g)))


register(EulerBernoulli())
register(Timoshenko())
