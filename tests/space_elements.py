"""Test-only 3-D element formulations, to check the space-frame plumbing (layout, files,
assembly, solvers, data) before and independently of the real space-frame elements.

- ``test-space-bar``: a truss member, axial stiffness E A / L and consistent mass
  rho A L / 6 [[2, 1], [1, 2]] in every translation; nothing on the rotations (support them).
- ``test-space-rod``: the bar plus torsion about its axis, G J / L (G / E from the material)
  and the polar inertia rho (Iy + Iz) L / 6 [[2, 1], [1, 2]] (model-3d.md's torsional mass);
  nothing on the two bending rotations (support them).

Both are trivially right and have closed forms; neither is the shipped frame element.
"""

from __future__ import annotations

import numpy as np

from fe_problem.dofs import SPACE_FRAME
from fe_problem.elements import register
from fe_problem.elements.base import ElementFormulation


def _axis(model, elements):
    c, pos = model.coordinates, model._node_pos
    d = c[[pos[e.node_j] for e in elements]] - c[[pos[e.node_i] for e in elements]]
    length = np.linalg.norm(d, axis=1)
    return length, d / length[:, None]


class SpaceBar(ElementFormulation):
    name = "test-space-bar"
    layout = SPACE_FRAME

    def stiffness(self, model, elements):
        length, u = _axis(model, elements)
        area = np.array([model.sections[e.section].area_m2 for e in elements])
        b = np.zeros((len(elements), 12))
        b[:, 0:3], b[:, 6:9] = -u, u
        return (area / length)[:, None, None] * b[:, :, None] * b[:, None, :]

    def mass(self, model, elements):
        length, _ = _axis(model, elements)
        area = np.array([model.sections[e.section].area_m2 for e in elements])
        out = np.zeros((len(elements), 12, 12))
        for a in range(3):
            out[:, a, a] = out[:, 6 + a, 6 + a] = 2.0
            out[:, a, 6 + a] = out[:, 6 + a, a] = 1.0
        return (area * length / 6.0)[:, None, None] * out

    def displaced(self, model, elements, ends, xi):
        return ends[:, None, 0:3] * (1 - xi)[None, :, None] + ends[:, None, 6:9] * xi[None, :, None]


class SpaceRod(SpaceBar):
    name = "test-space-rod"

    def stiffness(self, model, elements):
        length, u = _axis(model, elements)
        secs = [model.sections[e.section] for e in elements]
        g_over_e = np.array([model.materials[e.material].shear_modulus / model.materials[e.material].youngs_modulus_pa
                             for e in elements])
        b = np.zeros((len(elements), 12))
        b[:, 3:6], b[:, 9:12] = -u, u
        torsion = (g_over_e * np.array([s.j_m4 for s in secs]) / length)[:, None, None] * b[:, :, None] * b[:, None, :]
        return super().stiffness(model, elements) + torsion

    def mass(self, model, elements):
        length, u = _axis(model, elements)
        polar = np.array([model.sections[e.section].iy_m4 + model.sections[e.section].iz_m4 for e in elements])
        uu = u[:, :, None] * u[:, None, :]
        out = super().mass(model, elements)
        for (r, c), w in (((3, 3), 2.0), ((9, 9), 2.0), ((3, 9), 1.0), ((9, 3), 1.0)):
            out[:, r:r + 3, c:c + 3] += (polar * length / 6.0 * w)[:, None, None] * uu
        return out


register(SpaceBar())
register(SpaceRod())
