"""The space frame elements: Euler-Bernoulli and Timoshenko beams with an axial bar and a
torsion bar, on the nodal DOFs x, y, z, rx, ry, rz of `SPACE_FRAME`.

The local axes come from each element's ``orientation`` (OpenSees' vecxz, see
docs/model-format.md); the matrices from beam3d.py. The stiffness is per unit E with the
material's G / E fixed (``shear_modulus_pa``, or E / 2(1 + nu) when it is not given), so an
updated modulus scales E and G together and K stays linear in E; Timoshenko's shear ratios
depend on G / E only. Torsional inertia is the section's polar moment rho (Iy + Iz) in both
formulations (the file form's rule; OpenSees takes rho J, see beam3d.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np

from ..dofs import SPACE_FRAME
from . import beam3d
from .base import ElementFormulation, register

if TYPE_CHECKING:
    from ..model import Element, FrameModel


@dataclass(frozen=True)
class Geometry:
    """Lengths (m), rotations (n, 3, 3) and section properties of a group of elements."""

    length: np.ndarray
    r: np.ndarray
    area: np.ndarray
    iy: np.ndarray
    iz: np.ndarray
    j: np.ndarray
    shear_area: np.ndarray
    g_over_e: np.ndarray

    @classmethod
    def of(cls, model: FrameModel, elements: Sequence[Element]) -> "Geometry":
        """The geometry of `elements` of `model`."""
        xyz = np.asarray(model.coordinates, dtype=float)
        i = np.array([model.node_position(e.node_i) for e in elements], dtype=int)
        j = np.array([model.node_position(e.node_j) for e in elements], dtype=int)
        orientation = np.array([e.orientation for e in elements], dtype=float)
        r = beam3d.rotation(xyz[i], xyz[j], orientation)
        sec = [model.sections[e.section] for e in elements]
        mats = [model.materials[e.material] for e in elements]
        area = np.array([s.area_m2 for s in sec])
        return cls(beam3d.lengths(xyz[i], xyz[j]), r, area,
                   np.array([s.iy_m4 for s in sec]), np.array([s.iz_m4 for s in sec]),
                   np.array([s.j_m4 for s in sec]), area * np.array([s.shear_coefficient for s in sec]),
                   np.array([m.shear_modulus / m.youngs_modulus_pa for m in mats]))

    def to_global(self, local: np.ndarray) -> np.ndarray:
        """Local-axis element matrices (n, 12, 12) to global axes."""
        return beam3d.to_global(local, beam3d.transformation(self.r))


class _SpaceBeam(ElementFormulation):
    layout = SPACE_FRAME
    rotary = False

    def _phi(self, g: Geometry) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros_like(g.length), np.zeros_like(g.length)

    def stiffness(self, model, elements):
        g = Geometry.of(model, elements)
        phi_y, phi_z = self._phi(g)
        return g.to_global(beam3d.local_stiffness(g.length, g.area, g.iy, g.iz, g.g_over_e * g.j, phi_y, phi_z))

    def mass(self, model, elements):
        g = Geometry.of(model, elements)
        phi_y, phi_z = self._phi(g)
        return g.to_global(beam3d.local_mass(g.length, g.area, g.iy, g.iz, g.iy + g.iz, phi_y, phi_z, self.rotary))

    def displaced(self, model, elements, ends, xi):
        g = Geometry.of(model, elements)
        smooth = np.array([not any(model.end_releases(e)) and e.weak_zone is None for e in elements], dtype=bool)
        return beam3d.interpolate(g.length, g.r, ends, smooth, xi)


class EulerBernoulli3d(_SpaceBeam):
    """Hermite-cubic bending in both planes with consistent mass (axial, bending, torsional
    inertia rho (Iy + Iz)) and no rotary inertia of the section: OpenSees' elasticBeamColumn
    with -cMass, save its torsional mass (rho J there). A modulus profile along the element
    (`PROFILES`) scales axial, both bending planes and torsion alike (beam3d.weighted_stiffness).
    A weak zone (``weak_zone``, ``weak_zone_about``: a stretch whose bending stiffness about
    local y, local z or both is reduced) is built into the element by the flexibility
    formulation of each bending plane (beam3d.zone_stiffness, exact); the mass stays the
    beam's. Cracks (a rotational spring inside the element) are planar only."""

    name = "euler-bernoulli"
    supports_profile = True
    supports_weak_zone = True
    zone_planes = True

    def stiffness(self, model, elements):
        k = super().stiffness(model, elements)
        rows = [r for r, e in enumerate(elements) if e.weak_zone is not None]
        if rows:
            zoned = [elements[r] for r in rows]
            start, end, ratio = (np.array([e.weak_zone[c] for e in zoned]) for c in range(3))
            k[rows] = self.zone_stiffness(model, zoned, start, end, ratio, [e.weak_zone_about for e in zoned])
        return k

    def zone_stiffness(self, model, elements, start, end, ratio, about):
        g = Geometry.of(model, elements)
        ratio = np.asarray(ratio, dtype=float)
        ry = np.where(["ry" in a for a in about], ratio, 1.0)
        rz = np.where(["rz" in a for a in about], ratio, 1.0)
        return g.to_global(beam3d.zone_stiffness(g.length, g.area, g.iy, g.iz, g.g_over_e * g.j,
                                                 np.asarray(start, dtype=float), np.asarray(end, dtype=float), ry, rz))

    def profile_stiffness(self, model, element, weights):
        if element.weak_zone is not None:
            raise ValueError(f"element {element.id}: a modulus profile needs an element without a weak zone")
        g = Geometry.of(model, [element])
        return g.to_global(beam3d.weighted_stiffness(g.length, g.area, g.iy, g.iz, g.g_over_e * g.j, weights))


class Timoshenko3d(_SpaceBeam):
    """Shear-deformable bending in both planes (shear area kappa A each) with Przemieniecki's
    consistent mass and the rotary inertia of the section: OpenSees' ElasticTimoshenkoBeam3d
    with -cMass, save its torsional mass (rho J there)."""

    name = "timoshenko"
    rotary = True

    def _phi(self, g: Geometry) -> tuple[np.ndarray, np.ndarray]:
        return beam3d.shear_ratios(g.length, g.iy, g.iz, g.shear_area, g.g_over_e)


register(EulerBernoulli3d())
register(Timoshenko3d())
