"""A localised stiffness loss: a weak zone about one section depth wide at a position along an
element (the classical reduced-stiffness-zone model of a crack), one candidate per position
of a grid.

A crack bends its member with a kink. A modulus reduced over the whole element, uniformly or
along a profile, cannot follow that; a zone of reduced bending stiffness at the right place
can: its end-moment flexibility is the element's plus (1/r - 1)/(E I) times the integral of
b b^T over the zone (`elements.beam2d.zone_flexibility`, exact). The candidate's effect size
a is the zone's loss of bending stiffness, r = 1 - a; a = 0 is the model itself. Its
extension is the element carrying that zone (`Element.weak_zone`, a field of the model
file), so the written model gives exactly the fitted modes and a later round starts from
exactly what was fitted.

Width: the depth of the rectangle with the section's area and inertia, sqrt(12 I / A), at
most 0.2 of the element. Positions: the zone's centre at 0.2, 0.3, ..., 0.8 of the length,
moved inward where the zone would stick out. No zone at an element's very end: there a
crack and a flexible joint are the same thing, and the joint is the candidate that says so
(with zones at 0.1 and 0.9, 0.3 wide, one of the seed-2026 joint cases tied with a zone).
Once a zone is chosen, its centre is refined between the grid positions (rounds.py:
`zone_place` gives the zone at any centre).

On a space frame a zone weakens one bending plane: a candidate per element, place and
bending rotation `about` (local "ry": Iy, bending in the local x-z plane; "rz": Iz, the
x-y plane), its width the section's depth in that plane (sqrt(12 I / A) with that I), built
by the space element's flexibility formulation (`elements.beam3d.zone_stiffness`) and
written as the element's `weak_zone` with `weak_zone_about`. A planar zone bends about rz.

The batch of effect sizes is solved in one eigen-solve: the zone changes one element's
stiffness block (rank <= 4), added to the calibrated model's mass-normalised operator.
"""

from __future__ import annotations

import dataclasses
from typing import Iterator

import numpy as np

from ..assembly import AffineModel
from ..solver import ModalSolver, signed
from ..elements import beam2d, formulation
from ..elements.frame2d import Geometry
from ..model import FrameModel
from ..modal import frequencies_hz

#: Centres of the zone along the element (fractions of its length from node_i).
POSITIONS = tuple(np.round(np.arange(0.2, 0.81, 0.1), 2))
#: The zone's loss of bending stiffness: a grid dense toward a deep crack.
GRID = np.array([0.0, 0.005, 0.01, 0.02, 0.04, 0.07, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.85, 0.9,
                 0.93, 0.95, 0.97, 0.98, 0.99])
UPPER = 0.99
#: The widest zone, as a fraction of its element.
MAX_WIDTH = 0.2


def bending_rotations(model: FrameModel) -> tuple[str, ...]:
    """The bending rotations a zone of this model's elements may weaken: the planar frame's
    rz; a space frame's local ry and rz (one candidate each)."""
    return tuple(h for h in model.layout.hinges if h != "rx")


def zone_width(model: FrameModel, element_id: int, about: str = "rz") -> float:
    """The zone's width as a fraction of the element: the section's rectangle depth
    sqrt(12 I / A) in the bending plane of `about` over the length, at most `MAX_WIDTH`."""
    e = model.element(element_id)
    sec = model.sections[e.section]
    return min(float(np.sqrt(12.0 * sec.inertia_about(about) / sec.area_m2)) / model.element_length_m(element_id),
               MAX_WIDTH)


def zone_place(model: FrameModel, element_id: int, centre: float, about: str = "rz") -> tuple[float, float]:
    """(start, end) of the zone centred at `centre` (a fraction of the element), moved inward
    so that it lies inside the element."""
    w = zone_width(model, element_id, about)
    c = min(max(float(centre), 0.5 * w), 1.0 - 0.5 * w)
    return round(c - 0.5 * w, 6), round(c + 0.5 * w, 6)


def zone_places(model: FrameModel, element_id: int, about: str = "rz") -> list[tuple[float, float]]:
    """(start, end) of every zone tried in an element: centres at `POSITIONS`, each moved
    inward so that the zone lies inside the element; duplicates dropped."""
    out = []
    for c in POSITIONS:
        place = zone_place(model, element_id, c, about)
        if place not in out:
            out.append(place)
    return out


def with_zone(model: FrameModel, element_id: int, start: float, end: float, ratio: float,
              about: str = "rz") -> FrameModel:
    """A copy whose element carries a weak zone (start, end, modulus ratio) bending about
    `about` (a space element's ``weak_zone_about``); ratio 1: the model."""
    if ratio >= 1.0:
        return model
    planes = formulation(model.element(element_id).formulation, model.layout).zone_planes
    fields = {"weak_zone_about": (about,)} if planes else {}
    return model.replace(elements=tuple(dataclasses.replace(e, weak_zone=(start, end, float(ratio)), **fields)
                                        if e.id == element_id else e for e in model.elements))


class ElementBatch:
    """Modes of a model with one element's stiffness matrix changed, for a batch of changes,
    in one eigen-solve (the mass is the model's)."""

    def __init__(self, model: FrameModel, element_id: int, coords, n_modes: int, system: AffineModel):
        self.model, self.system, s = model, system, system._solver
        self.row = k = [e.id for e in model.elements].index(element_id)
        pos = {g: i for i, g in enumerate(system.dofmap.free)}
        dofs = system.dofmap.block_dofs(k)  # with a skew release's relative rotations
        self.local = np.array([i for i, d in enumerate(dofs) if d in pos])
        rows = np.array([pos[d] for d in dofs if d in pos])
        # the element's block in the mass-normalised, rigid-motion-free coordinates
        self.p = s._q.T @ s._linv[:, rows]
        self.shape_map = s._linv.T @ s._q
        self.coord_rows = system.nodal_rows(coords)
        self.n_modes = min(n_modes, system.n_elastic)

    def __call__(self, delta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Frequencies (b, k) Hz and shapes at the coordinates (b, n_coord, k) with the element's
        global stiffness changed by `delta` (b, n_el_dof, n_el_dof)."""
        s = self.system._solver
        delta = self.system.dofmap.element_block(self.row, delta)[1]
        d = delta[:, self.local[:, None], self.local[None, :]]
        a = s._a0 + self.p @ d @ self.p.T
        lam, y = np.linalg.eigh(a)
        sl = slice(s._skip, s._skip + self.n_modes)
        phi = self.shape_map @ y[:, :, sl]
        phi = signed(phi)  # the solvers' sign rule
        return frequencies_hz(lam[:, sl]), AffineModel.at_rows(phi, self.coord_rows)


def zone_stiffness(model: FrameModel, element_id: int, start: float, end: float, ratio: np.ndarray,
                   about: str = "rz") -> np.ndarray:
    """Global stiffness (b, k, k) of the element with a weak zone of each ratio in `ratio` (b,)
    bending about `about` (a space element: its formulation's `zone_stiffness`)."""
    e = model.element(element_id)
    b = ratio.shape[0]
    form = formulation(e.formulation, model.layout)
    if form.zone_planes:
        return model.element_modulus_pa(element_id) * form.zone_stiffness(
            model, [e] * b, np.full(b, start), np.full(b, end), ratio, [(about,)] * b)
    g = Geometry.of(model, [e])
    length, inertia = np.repeat(g.length, b), np.repeat(g.inertia, b)
    extra = beam2d.zone_flexibility(length, inertia, np.full(b, start), np.full(b, end), ratio)
    local = beam2d.flexibility_bending_stiffness(length, inertia, extra)
    local += beam2d.local_stiffness(length, np.repeat(g.area, b), np.zeros(b), np.zeros(b))
    return model.element_modulus_pa(element_id) * beam2d.to_global(local, beam2d.rotation(
        np.repeat(g.cos, b), np.repeat(g.sin, b)))


def zone_forwards(model: FrameModel, element_id: int, coords, n_modes: int, shared: dict,
                  places=None, about: str = "rz") -> Iterator[tuple]:
    """(start, end, forward) for every zone of the element bending about `about` (or for each
    (start, end) of `places`); `forward(a)` gives the modes for zone losses a (b,). The solver
    of the unextended model is built once per `shared`."""
    nominal = zone_stiffness(model, element_id, 0.0, 1.0, np.ones(1), about)[0]
    for start, end in zone_places(model, element_id, about) if places is None else places:
        def forward(a, start=start, end=end):
            a = np.clip(np.atleast_1d(np.asarray(a, dtype=float)), 0.0, UPPER)
            if "system" not in shared:
                shared["system"] = AffineModel(model)
            if not batched(shared["system"]):  # a solver without the operator: one model per size
                return _one_by_one(model, element_id, start, end, a, coords, n_modes, about)
            key = ("batch", element_id)
            if key not in shared:
                shared[key] = ElementBatch(model, element_id, coords, n_modes, shared["system"])
            return shared[key](zone_stiffness(model, element_id, start, end, 1.0 - a, about) - nominal)

        yield start, end, forward


def batched(system: AffineModel) -> bool:
    """Whether the solver is the dense one with its mass-normalised operator (a constant mass,
    projected); on the sparse path (large models) each size is solved as its own model."""
    return isinstance(system._solver, ModalSolver) and system._solver.mass_constant and not system._solver.condensed


def _one_by_one(model, element_id, start, end, a, coords, n_modes, about="rz"):
    """The same modes as `ElementBatch`, each from the extended model assembled afresh."""
    out = []
    for v in a:
        system = AffineModel(with_zone(model, element_id, start, end, 1.0 - v, about))
        lam, phi = system.eigen(np.zeros((1, 0)), min(n_modes, system.n_elastic), vectors=True)
        out.append((frequencies_hz(lam), system.at_rows(phi, system.nodal_rows(coords))))
    return np.concatenate([o[0] for o in out]), np.concatenate([o[1] for o in out])
