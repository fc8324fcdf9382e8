"""The first-order form of a candidate: how K and M change per unit effect size at a = 0, on
the few DOFs the effect touches (an element's ends, a node's translations, one DOF).

These terms let every candidate of a large model be screened from one set of modes
(screening.py) without building its own system. For mode i the change is

    D_i = dk - lambda_i dm + lambda_i^2 dm2,

affine in lambda for a stiffness, a mass or a spring (dm2 = 0). A joint made flexible is not:
a rotational spring of compliance c at an element end changes each mode by c times the
square of the dynamic end moment g_i = (K_e - lambda_i M_e) e_r, so
D_i = -(c / a) g_i g_i^T (exact to first order in c).

A model-form change (a member's depth, a node's position; modelform.py) changes the geometry
inside the element matrices, nonlinearly: its term is the derivative of the changed elements'
matrices by a central difference (`depth`, `node_move`), from their geometry alone, so that no
model is built per candidate (a 3,000-DOF frame has 6,000 such candidates).
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

from ..assembly import DofMap
from ..elements import beam2d, element_matrices, formulation, profile_stiffness
from ..elements.frame2d import Geometry
from ..model import FrameModel
from .zones import zone_stiffness

#: Relative step of the central differences of a model-form term (truncation ~1e-12, rounding
#: ~1e-10 of the term).
FORM_STEP = 1e-6


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

    # -- model-form terms (modelform.py) ------------------------------------------------------
    def plain_beam(self, element_id: int) -> bool:
        """Whether the element is a planar beam whose matrices follow from its geometry alone (no
        crack, no weak zone): the elements a model-form term is computed for."""
        e = self.model.elements[self.row[element_id]]
        return (self.model.layout.dimension == 2 and e.formulation in ("euler-bernoulli", "timoshenko")
                and e.crack_position is None and e.weak_zone is None)

    @functools.cached_property
    def _geometry(self) -> Geometry:
        return Geometry.of(self.model, self.model.elements)

    def _beam_matrices(self, rows: np.ndarray, g: Geometry) -> tuple[np.ndarray, np.ndarray]:
        """Global stiffness per unit modulus and mass per unit density (n, 6, 6) of the elements
        `rows` with the geometry `g` (arrays (n,)), as their formulations build them."""
        k, m = np.zeros((len(rows), 6, 6)), np.zeros((len(rows), 6, 6))
        names = np.array([self.model.elements[r].formulation for r in rows])
        for name in dict.fromkeys(names):
            form, sel = formulation(name, self.model.layout), names == name
            gs = Geometry(*(np.asarray(getattr(g, f))[sel] for f in Geometry.__dataclass_fields__))
            phi, rot = form._phi(gs), form._rotary(gs)
            k[sel] = gs.to_global(beam2d.local_stiffness(gs.length, gs.area, gs.inertia, phi))
            m[sel] = gs.to_global(beam2d.local_mass(gs.length, gs.area, rot, phi))
        return k, m

    def _sub(self, rows: np.ndarray, **changed) -> Geometry:
        g = self._geometry
        return dataclasses.replace(Geometry(*(np.asarray(getattr(g, f))[rows] for f in Geometry.__dataclass_fields__)),
                                   **changed)

    def _term(self, rows: np.ndarray, k_plus, k_minus, m_plus, m_minus, h: float) -> Term:
        """The term of elements `rows` from their matrices at +h and -h, on the union of their DOFs."""
        edofs = self.dofmap.element_dofs[rows]
        dofs, where = np.unique(edofs, return_inverse=True)
        where = where.reshape(edofs.shape)
        dk, dm = np.zeros((len(dofs), len(dofs))), np.zeros((len(dofs), len(dofs)))
        scale_k = self.modulus[rows][:, None, None] / (2.0 * h)
        scale_m = self.density[rows][:, None, None] / (2.0 * h)
        for j in range(len(rows)):  # an element's block added where its DOFs are in the union
            dk[np.ix_(where[j], where[j])] += (scale_k[j] * (k_plus[j] - k_minus[j]))
            dm[np.ix_(where[j], where[j])] += (scale_m[j] * (m_plus[j] - m_minus[j]))
        return Term(dofs, dk, dm)

    def depth(self, element_id: int, sign: float) -> Term:
        """The element's section (1 + sign a) times as deep at a = 0: area x (1 + sign a), inertia
        x (1 + sign a)^3 (modelform.member_depth); a plain beam only (`plain_beam`)."""
        rows = np.array([self.row[element_id]])
        g, h = self._sub(rows), FORM_STEP
        ends = [self._beam_matrices(rows, self._sub(rows, area=g.area * (1 + sign * t),
                                                    inertia=g.inertia * (1 + sign * t) ** 3)) for t in (h, -h)]
        return self._term(rows, ends[0][0], ends[1][0], ends[0][1], ends[1][1], h)

    def node_move(self, node: int, direction: str, sign: float) -> Term:
        """The node moved by sign a metres in `direction` ("x" or "y") at a = 0
        (modelform.moved_node): every plain beam at the node changes length and direction."""
        model = self.model
        rows = np.array([k for k, e in enumerate(model.elements) if node in (e.node_i, e.node_j)])
        at, pos = model.coordinates, model._node_pos
        xi = at[[pos[model.elements[r].node_i] for r in rows]]
        xj = at[[pos[model.elements[r].node_j] for r in rows]]
        unit = np.array([1.0, 0.0]) if direction == "x" else np.array([0.0, 1.0])
        # +1 where the node is the element's node_j (the element's vector grows with the move), -1 at node_i
        end = np.array([1.0 if model.elements[r].node_j == node else -1.0 for r in rows])
        h = FORM_STEP * float(self._geometry.length[rows].min())
        mats = []
        for t in (h, -h):
            d = xj[:, :2] - xi[:, :2] + (sign * t) * end[:, None] * unit[None, :]
            length = np.hypot(d[:, 0], d[:, 1])
            mats.append(self._beam_matrices(rows, self._sub(rows, length=length, cos=d[:, 0] / length,
                                                            sin=d[:, 1] / length)))
        return self._term(rows, mats[0][0], mats[1][0], mats[0][1], mats[1][1], h)
