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
from .zones import UPPER, bending_rotations, zone_places, zone_stiffness

#: The forward-difference step of a weak zone's term (its loss of bending stiffness).
ZONE_STEP = 1e-6

#: The a up to which a space frame's weak-zone term is the chord (`LocalMatrices.zone`): the
#: candidates' upper bound, so that the screen's linear step spans every zone it may fit.
SPACE_ZONE_CHORD = UPPER

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
        return self._element(k, per_unit_a * ke, np.zeros_like(ke))

    def zone(self, element_id: int, start: float, end: float, about: str = "rz") -> Term:
        """A weak zone (start, end) of the element losing a of its bending stiffness about
        `about` (zones.py). Planar: at a = 0, the derivative of the element's exact stiffness,
        by a forward difference (relative error ~1e-6: enough to rank candidates). Space: the
        chord from a = 0 to a = `SPACE_ZONE_CHORD` (the change of the element's exact stiffness
        there, over that a), so that the first-order screen, whose step is clipped to the
        candidate's upper bound, reaches a deep zone: the zone's change grows as a / (1 - a),
        in a direction that hardly turns (a crack's is rank one, fixed), and the tangent at
        a = 0 reaches a tenth of a zone of 90 % loss (a hidden 90 % zone in a frame3d column
        screened at 0.1 to 3.5 of chi^2 drop against 80 for the joints beside it; the planar
        tangent is kept as it was). The zones of the grid's places are computed for every
        element at once on first use (`_zone_grid`, `_space_zone_grid`: one call per zone was
        10 % of a 3,000-DOF diagnosis); any other place as its own."""
        k = self.row[element_id]
        if formulation(self.model.element(element_id).formulation, self.model.layout).zone_planes:
            grid, key, step = self._space_zone_grid, (element_id, start, end, about), SPACE_ZONE_CHORD
        else:
            grid, key, step = self._zone_grid, (element_id, start, end), ZONE_STEP
        if key in grid:
            dk = grid[key]
        else:
            pair = zone_stiffness(self.model, element_id, start, end, np.array([1.0, 1.0 - step]), about)
            dk = (pair[1] - pair[0]) / step
        return self._element(k, dk, np.zeros_like(dk))

    @functools.cached_property
    def _space_zone_grid(self) -> dict[tuple[int, float, float, str], np.ndarray]:
        """(element id, start, end, about) -> the zone's chord dK/da (`zone`) for every place of
        `zones.zone_places` and bending rotation of every space element that can carry one:
        its formulation's `zone_stiffness` on all of them in one batch."""
        model = self.model
        keys, els = [], []
        for e in model.elements:
            form = formulation(e.formulation, model.layout)
            if not (form.zone_planes and form.supports_weak_zone and e.weak_zone is None):
                continue
            for about in bending_rotations(model):
                for start, end in zone_places(model, e.id, about):
                    keys.append((e.id, start, end, about))
                    els.append(e)
        out: dict = {}
        for name in dict.fromkeys(e.formulation for e in els):
            sel = [i for i, e in enumerate(els) if e.formulation == name]
            pairs = [els[i] for i in sel for _ in (0, 1)]          # each place at ratio 1 and 1 - chord
            ratio = np.tile([1.0, 1.0 - SPACE_ZONE_CHORD], len(sel))
            start = np.repeat([keys[i][1] for i in sel], 2)
            end = np.repeat([keys[i][2] for i in sel], 2)
            about = [(keys[i][3],) for i in sel for _ in (0, 1)]
            full = formulation(name, model.layout).zone_stiffness(model, pairs, start, end, ratio, about)
            full *= np.repeat(self.modulus[[self.row[keys[i][0]] for i in sel]], 2)[:, None, None]
            dk = (full[1::2] - full[0::2]) / SPACE_ZONE_CHORD
            out.update((keys[i], dk[j]) for j, i in enumerate(sel))
        return out

    @functools.cached_property
    def _zone_grid(self) -> dict[tuple[int, float, float], np.ndarray]:
        """(element id, start, end) -> the zone's dK/da for every place of `zones.zone_places` of
        every element that can carry one: `zones.zone_stiffness`'s arithmetic on all of them in
        one batch (each entry the same operations on the same numbers as a call of its own)."""
        model = self.model
        keys, rows = [], []
        for k, e in enumerate(model.elements):
            form = formulation(e.formulation, model.layout)
            if not (form.supports_crack and not form.zone_planes
                    and e.crack_position is None and e.weak_zone is None):
                continue
            for start, end in zone_places(model, e.id):
                keys.append((e.id, start, end))
                rows.append(k)
        if not keys:
            return {}
        g = self._geometry  # planar beams only from here
        rows = np.repeat(np.array(rows), 2)                    # each place at ratio 1 and 1 - h
        ratio = np.tile([1.0, 1.0 - ZONE_STEP], len(keys))
        start = np.repeat([key[1] for key in keys], 2)
        end = np.repeat([key[2] for key in keys], 2)
        length, inertia = g.length[rows], g.inertia[rows]
        extra = beam2d.zone_flexibility(length, inertia, start, end, ratio)
        local = beam2d.flexibility_bending_stiffness(length, inertia, extra)
        local += beam2d.local_stiffness(length, g.area[rows], np.zeros(len(rows)), np.zeros(len(rows)))
        full = self.modulus[rows][:, None, None] * beam2d.to_global(local, beam2d.rotation(g.cos[rows], g.sin[rows]))
        dk = (full[1::2] - full[0::2]) / ZONE_STEP
        return {key: dk[i] for i, key in enumerate(keys)}

    def density_change(self, element_id: int, per_unit_a: float) -> Term:
        """The element's density changed by `per_unit_a` kg/m^3 per unit a."""
        k = self.row[element_id]
        return self._element(k, np.zeros_like(self.m_el[k]), per_unit_a * self.m_el[k])

    def _element(self, k: int, dk: np.ndarray, dm: np.ndarray) -> Term:
        """The term of element matrices dk, dm of the element at row k, on the DOFs they act on
        (`DofMap.element_block`: a skew-released element's relative rotations too)."""
        dofs, dk = self.dofmap.element_block(k, dk)
        return Term(dofs, dk, self.dofmap.element_block(k, dm)[1])

    def node_mass(self, node: int) -> Term:
        """A lumped mass of a kg at `node` (every translation)."""
        lay = self.model.layout
        dofs = self.dofmap.node_dofs[node][[lay.position(d) for d in lay.translations]]
        return Term(dofs, np.zeros((len(dofs), len(dofs))), np.eye(len(dofs)))

    def ground_spring(self, node: int, direction: str, per_unit_a: float) -> Term:
        """A spring to ground of `per_unit_a` N/m per unit a at one DOF."""
        dofs = np.array([self.dofmap.dof(node, direction, self.model)])
        return Term(dofs, np.array([[per_unit_a]]), np.zeros((1, 1)))

    def joint(self, element_id: int, node: int, ref: float, rotation=None) -> Term:
        """The end of `element_id` at `node` tied by a spring of compliance a / ref (rad/N m) in
        the node's rotation `rotation`: a rotation name (default: the layout's one hinge
        rotation), or on a space frame a global unit axis (3,) (a local axis of the element,
        skew or not). Through `DofMap.element_block`: an element with a skew release already
        acts on its relative rotations too."""
        k = self.row[element_id]
        kr, mr, _ = self.joint_columns(element_id, node, rotation)
        dofs, dk = self.dofmap.element_block(k, -np.outer(kr, kr) / ref)
        return Term(dofs, dk, self.dofmap.element_block(k, -(np.outer(mr, kr) + np.outer(kr, mr)) / ref)[1],
                    self.dofmap.element_block(k, -np.outer(mr, mr) / ref)[1])

    def joint_columns(self, element_id: int, node: int, rotation=None):
        """The element's stiffness kr (N m/rad per DOF unit) and mass mr columns (its element DOFs,
        global components) for a unit rotation of its end at `node` about `rotation` (as
        `joint`), and that unit rotation `turn` (the element DOFs' weights): the released end's
        coupling to the element (`joint`, `reduced.SharedBasis.joint`)."""
        k = self.row[element_id]
        e = self.model.elements[k]
        lay = self.model.layout
        o = 0 if node == e.node_i else lay.per_node
        turn = np.zeros(2 * lay.per_node)
        if rotation is None or isinstance(rotation, str):
            r = o + lay.position(lay.rotation if rotation is None else rotation)
            turn[r] = 1.0
            return self.modulus[k] * self.k_el[k][:, r], self.density[k] * self.m_el[k][:, r], turn
        # the end's rotation about the axis: its rotation rows times the axis' components
        turn[[o + lay.position(d) for d in ("rx", "ry", "rz")]] = rotation
        return self.modulus[k] * (self.k_el[k] @ turn), self.density[k] * (self.m_el[k] @ turn), turn

    # -- model-form terms (modelform.py) ------------------------------------------------------
    def plain_beam(self, element_id: int) -> bool:
        """Whether the element is a planar beam whose matrices follow from its geometry alone (no
        crack, no weak zone): the elements a model-form term is computed for."""
        return bool(self._plain[self.row[element_id]])

    def plain_node(self, node: int) -> bool:
        """Whether every element at the node is a plain beam (`plain_beam`)."""
        return bool(self._plain[self.node_elements.get(node, [])].all())

    @functools.cached_property
    def _plain(self) -> np.ndarray:
        return np.array([self.model.layout.planar and e.formulation in ("euler-bernoulli", "timoshenko")
                         and e.crack_position is None and e.weak_zone is None for e in self.model.elements], dtype=bool)

    @functools.cached_property
    def node_elements(self) -> dict[int, list[int]]:
        """node -> the rows (in model.elements) of the elements at it."""
        out: dict[int, list[int]] = {}
        for k, e in enumerate(self.model.elements):
            out.setdefault(e.node_i, []).append(k)
            out.setdefault(e.node_j, []).append(k)
        return out

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

    def _central(self, rows: np.ndarray, plus: Geometry, minus: Geometry, h) -> tuple[np.ndarray, np.ndarray]:
        """d K_e / da and d M_e / da (n, 6, 6) of the elements `rows` (modulus and density
        included) by the central difference of their matrices at geometries +h and -h."""
        (kp, mp), (km, mm) = self._beam_matrices(rows, plus), self._beam_matrices(rows, minus)
        h = np.broadcast_to(np.asarray(h, dtype=float), (len(rows),))[:, None, None]
        return (self.modulus[rows][:, None, None] * (kp - km) / (2.0 * h),
                self.density[rows][:, None, None] * (mp - mm) / (2.0 * h))

    def _term(self, rows, dk_el: np.ndarray, dm_el: np.ndarray, sign: float) -> Term:
        """sign x the element derivatives of `rows` assembled on the union of their DOFs."""
        edofs = self.dofmap.element_dofs[rows]
        dofs, where = np.unique(edofs, return_inverse=True)
        where = where.reshape(edofs.shape)
        dk, dm = np.zeros((len(dofs), len(dofs))), np.zeros((len(dofs), len(dofs)))
        for j in range(len(rows)):  # an element's block added where its DOFs are in the union
            dk[np.ix_(where[j], where[j])] += dk_el[j]
            dm[np.ix_(where[j], where[j])] += dm_el[j]
        return Term(dofs, sign * dk, sign * dm)

    @functools.cached_property
    def _depths(self) -> tuple[np.ndarray, np.ndarray]:
        """d K_e, d M_e per unit a of every element's depth x (1 + a), at once (plain beams' rows)."""
        rows = np.arange(len(self.model.elements))
        g, h = self._geometry, FORM_STEP
        return self._central(rows, *(self._sub(rows, area=g.area * (1 + t), inertia=g.inertia * (1 + t) ** 3)
                                     for t in (h, -h)), h)

    def depth(self, element_id: int, sign: float) -> Term:
        """The element's section (1 + sign a) times as deep at a = 0: area x (1 + sign a), inertia
        x (1 + sign a)^3 (modelform.member_depth); a plain beam only (`plain_beam`)."""
        k = self.row[element_id]
        dk, dm = self._depths
        return self._term([k], dk[k:k + 1], dm[k:k + 1], sign)

    @functools.cached_property
    def _moves(self) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """For "x" and "y": every (element, end) pair's d K_e, d M_e per metre of its end node's move
        (one batch for all nodes), and the pairs' element rows."""
        model, g = self.model, self._geometry
        rows = np.concatenate([np.arange(len(model.elements))] * 2)
        at, pos = model.coordinates, model._node_pos
        xi = at[[pos[e.node_i] for e in model.elements]][:, :2]
        xj = at[[pos[e.node_j] for e in model.elements]][:, :2]
        d0 = np.concatenate([xj - xi] * 2)
        end = np.repeat([-1.0, 1.0], len(model.elements))  # moving node_i shortens d, node_j lengthens it
        # the step: FORM_STEP of the shortest member at the node (as node_move's own rule)
        shortest = {n: float(g.length[r].min()) for n, r in self.node_elements.items()}
        nodes = np.array([e.node_i for e in model.elements] + [e.node_j for e in model.elements])
        h = FORM_STEP * np.array([shortest[n] for n in nodes])
        out = {}
        for direction, unit in (("x", np.array([1.0, 0.0])), ("y", np.array([0.0, 1.0]))):
            geos = []
            for t in (h, -h):
                d = d0 + (t * end)[:, None] * unit[None, :]
                length = np.hypot(d[:, 0], d[:, 1])
                geos.append(self._sub(rows, length=length, cos=d[:, 0] / length, sin=d[:, 1] / length))
            out[direction] = self._central(rows, *geos, h)
        return out

    def node_move(self, node: int, direction: str, sign: float) -> Term:
        """The node moved by sign a metres in `direction` ("x" or "y") at a = 0
        (modelform.moved_node): every plain beam at the node changes length and direction."""
        rows = np.array(self.node_elements[node])
        n_el = len(self.model.elements)
        pairs = np.where(np.array([self.model.elements[r].node_j == node for r in rows]), rows + n_el, rows)
        dk, dm = self._moves[direction]
        return self._term(rows, dk[pairs], dm[pairs], sign)
