"""The first-order form of a candidate: how K and M change per unit effect size at a = 0, on
the few DOFs the effect touches (an element's ends, a node's translations, one DOF).

These terms let every candidate of a large model be screened from one set of modes
(screening.py) without building its own system. For mode i the change is

    D_i = dk - lambda_i dm + lambda_i^2 dm2,

affine in lambda for a stiffness, a mass or a spring (dm2 = 0). A joint made flexible is not:
a rotational spring of compliance c at an element end changes each mode by c times the
square of the dynamic end moment g_i = (K_e - lambda_i M_e) e_r, so
D_i = -(c / a) g_i g_i^T (exact to first order in c).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..assembly import DofMap
from ..elements import element_matrices, profile_stiffness
from ..model import FrameModel
from .zones import zone_stiffness


@dataclass(frozen=True)
class Term:
    """dK/da, dM/da (and the lambda^2 part dm2) of one candidate at a = 0, (k, k) on the
    model's DOFs `dofs` (k,) (indices in `DofMap.of(model)` numbering)."""

    dofs: np.ndarray
    dk: np.ndarray
    dm: np.ndarray
    dm2: np.ndarray | None = None


class LocalMatrices:
    """Element matrices and DOF indices of one model, computed once for all its candidates."""

    def __init__(self, model: FrameModel):
        self.model = model
        self.dofmap = DofMap.of(model)
        self.k_el, self.m_el = element_matrices(model)   # per unit modulus / per unit density
        self.row = {e.id: k for k, e in enumerate(model.elements)}

    @functools.cached_property
    def modulus(self) -> np.ndarray:
        return np.array([self.model.element_modulus_pa(e.id) for e in self.model.elements])

    @functools.cached_property
    def density(self) -> np.ndarray:
        return np.array([self.model.materials[e.material].density_kg_m3 for e in self.model.elements])

    def stiffness(self, element_id: int, per_unit_a: float, profile: str = "uniform") -> Term:
        """The element's modulus changed by `per_unit_a` Pa per unit a (with a modulus profile)."""
        k = self.row[element_id]
        if profile == "uniform":
            ke = self.k_el[k]
        else:
            ke = profile_stiffness(self.model, self.model.elements[k], profile)[0]
        z = np.zeros_like(ke)
        return Term(self.dofmap.element_dofs[k], per_unit_a * ke, z)

    def zone(self, element_id: int, start: float, end: float) -> Term:
        """A weak zone (start, end) of the element losing a of its bending stiffness (zones.py),
        at a = 0: the derivative of the element's exact stiffness, by a forward difference
        (relative error ~1e-6: enough to rank candidates)."""
        h = 1e-6
        pair = zone_stiffness(self.model, element_id, start, end, np.array([1.0, 1.0 - h]))
        k = self.row[element_id]
        return Term(self.dofmap.element_dofs[k], (pair[1] - pair[0]) / h, np.zeros_like(pair[0]))

    def density_change(self, element_id: int, per_unit_a: float) -> Term:
        """The element's density changed by `per_unit_a` kg/m^3 per unit a."""
        k = self.row[element_id]
        return Term(self.dofmap.element_dofs[k], np.zeros_like(self.m_el[k]), per_unit_a * self.m_el[k])

    def node_mass(self, node: int) -> Term:
        """A lumped mass of a kg at `node` (every translation)."""
        lay = self.model.layout
        dofs = self.dofmap.node_dofs[node][[lay.position(d) for d in lay.translations]]
        return Term(dofs, np.zeros((len(dofs), len(dofs))), np.eye(len(dofs)))

    def ground_spring(self, node: int, direction: str, per_unit_a: float) -> Term:
        """A spring to ground of `per_unit_a` N/m per unit a at one DOF."""
        dofs = np.array([self.dofmap.dof(node, direction, self.model)])
        return Term(dofs, np.array([[per_unit_a]]), np.zeros((1, 1)))

    def joint(self, element_id: int, node: int, ref: float, rotation: str | None = None) -> Term:
        """The end of `element_id` at `node` tied by a spring of compliance a / ref (rad/N m) in
        the node's rotation `rotation` (default: the layout's one hinge rotation)."""
        k = self.row[element_id]
        e = self.model.elements[k]
        lay = self.model.layout
        r = (0 if node == e.node_i else lay.per_node) + lay.position(lay.rotation if rotation is None else rotation)
        kr = self.modulus[k] * self.k_el[k][:, r]
        mr = self.density[k] * self.m_el[k][:, r]
        return Term(self.dofmap.element_dofs[k], -np.outer(kr, kr) / ref,
                    -(np.outer(mr, kr) + np.outer(kr, mr)) / ref, -np.outer(mr, mr) / ref)
