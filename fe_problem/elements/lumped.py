"""Lumped-mass variants of the beam formulations: the same stiffness, the mass of each element
as rho A L / 2 on every translation of each end and nothing on the rotations.

This is the default mass of Nastran's CBAR/CBEAM (lumped unless PARAM COUPMASS) and of
OpenSees' elasticBeamColumn and ElasticTimoshenkoBeam without ``-cMass``; a model imported
from either keeps it (fe_problem/model/nastran.py, opensees.py). Registered for both layouts
as "<name>-lumped" ("euler-bernoulli-lumped", "timoshenko-lumped"): an element's
``formulation`` names it like any other.
"""

from __future__ import annotations

import numpy as np

from . import frame2d, frame3d
from .base import coordinates, register

#: The suffix of a lumped-mass formulation's name.
LUMPED = "-lumped"


def lumped_mass(model, elements) -> np.ndarray:
    """Global-axis lumped mass per unit density (n, k, k): A L / 2 on each translation of each
    end (`layout.translations`), zero on the rotations (isotropic: the same in every axes)."""
    layout = model.layout
    at, pos = coordinates(model), model._node_pos
    ends = np.array([(pos[e.node_i], pos[e.node_j]) for e in elements], dtype=int).reshape(-1, 2)
    length = np.linalg.norm(at[ends[:, 1]] - at[ends[:, 0]], axis=1)
    area = np.array([model.sections[e.section].area_m2 for e in elements])
    per = layout.per_node
    m = np.zeros((len(elements), 2 * per, 2 * per))
    idx = [o * per + layout.position(d) for o in (0, 1) for d in layout.translations]
    m[:, idx, idx] = (area * length / 2.0)[:, None]
    return m


def _lumped(base: type) -> type:
    """A subclass of the formulation `base` with its name + LUMPED and `lumped_mass`."""
    return type(base.__name__ + "Lumped", (base,), {
        "name": base.name + LUMPED, "mass": lambda self, model, elements: lumped_mass(model, elements),
        "__doc__": f"{base.__name__} stiffness with lumped mass (rho A L / 2 per end translation)."})


for _base in (frame2d.EulerBernoulli, frame2d.Timoshenko, frame3d.EulerBernoulli3d, frame3d.Timoshenko3d):
    register(_lumped(_base)())
