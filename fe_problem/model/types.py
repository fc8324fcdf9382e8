"""The model types: nodes, elements, sections, materials, masses, springs, supports, and
the `FrameModel` that holds them.

A `FrameModel` is a frozen value, validated when built (validate.py). Its nodal DOFs are
described by its `layout` (dofs.py); file I/O is in io.py, edits in edits.py.

Units are SI throughout: metres, pascals, kilograms, newtons per metre (translational
springs) and newton-metres per radian (rotational springs).
"""

from __future__ import annotations

import contextvars
import dataclasses
import functools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..dofs import DEFAULT_LAYOUT, DofLayout
from .validate import validate

#: The model `FrameModel.replace` copies, while the copy is validated (validate.py's `base`).
_REPLACING: contextvars.ContextVar = contextvars.ContextVar("_REPLACING", default=None)

#: The DOF names of a node of the default layout, in their order (``DEFAULT_LAYOUT.names``).
DIRECTIONS = DEFAULT_LAYOUT.names

@dataclass(frozen=True)
class Node:
    """A node, coordinates in metres (a planar model's nodes lie in the x-y plane: z = 0)."""

    id: int
    x: float
    y: float
    z: float = 0.0


@dataclass(frozen=True)
class Material:
    """Isotropic linear elastic material: modulus (Pa), density (kg/m^3), Poisson's ratio, and
    the shear modulus (Pa; None: E / 2(1 + nu), see `shear_modulus`)."""

    youngs_modulus_pa: float
    density_kg_m3: float
    poisson_ratio: float = 0.3
    shear_modulus_pa: float | None = None

    @property
    def shear_modulus(self) -> float:
        """The shear modulus G (Pa): `shear_modulus_pa`, or E / 2(1 + nu) when that is None."""
        if self.shear_modulus_pa is None:
            return self.youngs_modulus_pa / (2.0 * (1.0 + self.poisson_ratio))
        return self.shear_modulus_pa


@dataclass(frozen=True)
class Section:
    """Beam cross-section: area (m^2), the shear coefficient kappa (shear area = kappa * area,
    Timoshenko elements only) and second moments of area (m^4).

    A planar model's section has `inertia_m4` (bending in the frame plane). A space model's
    has `iy_m4` (bending in the element's local x-z plane, about local y), `iz_m4` (local x-y
    plane, about local z) and `j_m4` (the torsion constant), and no `inertia_m4`; the local
    axes come from the element's `orientation` (docs/model-format.md)."""

    area_m2: float
    inertia_m4: float | None = None
    shear_coefficient: float = 5.0 / 6.0
    iy_m4: float | None = None
    iz_m4: float | None = None
    j_m4: float | None = None

    def inertia_about(self, rotation: str) -> float:
        """The second moment (m^4) resisting a rotation of the element about its local axis
        `rotation`: "rz" bending (a planar section's `inertia_m4`, a space section's `iz_m4`),
        "ry" bending (`iy_m4`), "rx" torsion (`j_m4`, the torsion constant)."""
        if self.inertia_m4 is not None:
            if rotation != "rz":
                raise ValueError(f"a planar section bends about rz only, not {rotation!r}")
            return self.inertia_m4
        return {"rz": self.iz_m4, "ry": self.iy_m4, "rx": self.j_m4}[rotation]


@dataclass(frozen=True)
class Element:
    """A 2-node frame element from node_i to node_j.

    ``release_i`` / ``release_j`` (planar models): None for a rigid connection of the element
    end's rotation to its node; otherwise the element end gets a rotation of its own, tied to
    the node's rotation by a rotational spring of that stiffness (N m/rad; 0 is a pin).
    ``releases_i`` / ``releases_j`` (space models): the same per rotation, as pairs
    (rotation, stiffness) with the rotation named in the element's local axes ("rx" torsion,
    "ry", "rz" bending; `DofLayout.hinges`), each rotation at most once; () is rigid.
    `FrameModel.end_releases` reads either form.
    ``orientation`` (space models): a vector in the element's local x-z plane (OpenSees'
    vecxz); local x runs from node_i to node_j, local y = orientation x local x, local z =
    local x x local y (`FrameModel.local_axes`).
    ``youngs_modulus_pa`` overrides the material's modulus for this element (an updated model).
    ``crack_position`` / ``crack_stiffness``: a crack as a rotational spring (N m/rad) at that
    fraction of the length from node_i, inside the element (flexibility formulation, no new
    node; Euler-Bernoulli only). The crack's stiffness scales with the element's modulus
    when that is updated, as a fracture-mechanics crack compliance (proportional to 1/E) does.
    ``weak_zone``: (start, end, modulus_ratio): the bending stiffness is modulus_ratio * E I
    from `start` to `end` (fractions of the length from node_i) and E I elsewhere (a reduced-
    stiffness zone, the classical crack model of a zone about a section depth wide;
    flexibility formulation, exact; mass unchanged; Euler-Bernoulli only).
    ``weak_zone_about`` (space models): the local bending rotations the zone weakens, "ry"
    (bending in the local x-z plane, Iy), "rz" (the x-y plane, Iz) or both; () on a planar
    element (its zone bends about rz, the only bending rotation).
    """

    id: int
    node_i: int
    node_j: int
    section: str
    material: str
    formulation: str = "euler-bernoulli"
    release_i: float | None = None
    release_j: float | None = None
    youngs_modulus_pa: float | None = None
    crack_position: float | None = None
    crack_stiffness: float | None = None
    weak_zone: tuple[float, float, float] | None = None
    orientation: tuple[float, float, float] | None = None
    releases_i: tuple[tuple[str, float], ...] = ()
    releases_j: tuple[tuple[str, float], ...] = ()
    weak_zone_about: tuple[str, ...] = ()


@dataclass(frozen=True)
class LumpedMass:
    """A lumped mass (kg, acting in every translation) and rotary inertia (kg m^2, on every
    rotation of the node: the planar frame's rz; a space frame's rx, ry, rz alike) at a node."""

    node: int
    mass_kg: float
    inertia_kg_m2: float = 0.0


@dataclass(frozen=True)
class Spring:
    """A linear spring between two nodal DOFs, or from one DOF to ground (dof_b None).

    Stiffness in N/m between translations, N m/rad between rotations.
    """

    id: int
    dof_a: tuple[int, str]
    dof_b: tuple[int, str] | None
    stiffness: float


@dataclass(frozen=True)
class Support:
    """Directions fixed to ground at a node."""

    node: int
    directions: tuple[str, ...]


@dataclass(frozen=True)
class FrameModel:
    """A frame model. Nodal DOFs are node-major, each node with the DOFs of `layout`
    (`PLANAR_FRAME`: x, y, rz; `SPACE_FRAME`: x, y, z, rx, ry, rz). Nothing outside the layout
    and the element formulations assumes which: ask `layout` and `coordinates`."""

    name: str
    nodes: tuple[Node, ...]
    materials: dict[str, Material]
    sections: dict[str, Section]
    elements: tuple[Element, ...]
    masses: tuple[LumpedMass, ...] = ()
    springs: tuple[Spring, ...] = ()
    supports: tuple[Support, ...] = ()
    measured_dofs: tuple[tuple[int, str], ...] = ()
    excitation: tuple[int, str] | None = None
    description: str = ""
    source: str = field(default="<memory>", compare=False)
    layout: DofLayout = field(default=DEFAULT_LAYOUT, repr=False)
    #: Where the model came from and how it was read (a JSON object, kept as it is: an imported
    #: model's ``"import"`` record, fe_problem/model/nastran.py and opensees.py); no physics.
    meta: dict = field(default_factory=dict, compare=False, repr=False)

    def __post_init__(self) -> None:
        validate(self, _REPLACING.get())

    # -- lookups ---------------------------------------------------------------------
    @property
    def node_ids(self) -> tuple[int, ...]:
        """Node ids in model order."""
        return tuple(n.id for n in self.nodes)

    @property
    def element_ids(self) -> tuple[int, ...]:
        """Element ids in model order."""
        return tuple(e.id for e in self.elements)

    # Lookups by id are dictionaries built once per model (a frozen value): O(1), so a model
    # of thousands of nodes is assembled and validated in linear time.
    @functools.cached_property
    def _node_pos(self) -> dict[int, int]:
        return {n.id: k for k, n in enumerate(self.nodes)}

    @functools.cached_property
    def _element_pos(self) -> dict[int, int]:
        return {e.id: k for k, e in enumerate(self.elements)}

    @functools.cached_property
    def _at_node(self) -> dict[int, tuple[Element, ...]]:
        at: dict[int, list[Element]] = {}
        for e in self.elements:
            for n in dict.fromkeys((e.node_i, e.node_j)):
                at.setdefault(n, []).append(e)
        return {n: tuple(es) for n, es in at.items()}

    def elements_at(self, node_id: int) -> tuple[Element, ...]:
        """The elements with an end at this node, in model order (empty if none)."""
        return self._at_node.get(node_id, ())

    def node(self, node_id: int) -> Node:
        """The node with this id (KeyError if none)."""
        return self.nodes[self.node_position(node_id)]

    def element(self, element_id: int) -> Element:
        """The element with this id (KeyError if none)."""
        try:
            return self.elements[self._element_pos[element_id]]
        except (KeyError, TypeError):  # TypeError: an unhashable id
            raise KeyError(f"model {self.name!r} has no element {element_id}") from None

    @property
    def dofs(self) -> tuple[tuple[int, str], ...]:
        """All nodal DOFs in node-major order, one (node id, direction) per DOF."""
        return tuple((n.id, d) for n in self.nodes for d in self.layout.names)

    @property
    def n_dof(self) -> int:
        """Number of nodal DOFs."""
        return self.layout.n_dof(len(self.nodes))

    def node_position(self, node_id: int) -> int:
        """Position of a node in `nodes` (0-based); KeyError if the model has no such node."""
        try:
            return self._node_pos[node_id]
        except (KeyError, TypeError):  # TypeError: an unhashable id
            raise KeyError(f"model {self.name!r} has no node {node_id}") from None

    def dof_index(self, node_id: int, direction: str) -> int:
        """Position of a nodal DOF in `dofs`."""
        self.layout.position(direction)
        return self.layout.index(self.node_position(node_id), direction)

    def node_dof_indices(self, node_id: int, names=None) -> tuple[int, ...]:
        """Positions in `dofs` of a node's DOFs `names` (default: all of them, layout order)."""
        pos = self.node_position(node_id)
        return tuple(self.layout.index(pos, d) for d in (self.layout.names if names is None else names))

    @functools.cached_property
    def coordinates(self) -> np.ndarray:
        """Node coordinates (n_nodes, layout.dimension) in metres, model order: (x, y) of a
        planar model, (x, y, z) of a space model. Read-only."""
        axes = ("x", "y", "z")[: self.layout.dimension]
        out = np.array([[getattr(n, a) for a in axes] for n in self.nodes], dtype=float).reshape(-1, len(axes))
        out.flags.writeable = False
        return out

    def element_vector_m(self, element_id: int) -> np.ndarray:
        """From node_i to node_j of an element (layout.dimension,), metres."""
        e = self.element(element_id)
        c = self.coordinates
        return c[self.node_position(e.node_j)] - c[self.node_position(e.node_i)]

    def element_length_m(self, element_id: int) -> float:
        """Length of an element (m)."""
        return math.hypot(*self.element_vector_m(element_id))

    def local_axes(self, element_id: int) -> np.ndarray:
        """The element's local axes as rows (3, 3) of unit vectors in global (x, y, z): local
        x from node_i to node_j; a space element's local y = orientation x local x and
        local z = local x x local y (OpenSees' vecxz convention); a planar element's local z
        is the global z (its bending axis) and local y = local z x local x."""
        d = np.zeros(3)
        d[: self.layout.dimension] = self.element_vector_m(element_id)
        ex = d / np.linalg.norm(d)
        v = self.element(element_id).orientation
        if self.layout.dimension == 2 or v is None:
            ez = np.array([0.0, 0.0, 1.0])
            ey = np.cross(ez, ex)
            return np.array([ex, ey, ez])
        ey = np.cross(np.asarray(v, dtype=float), ex)
        ey /= np.linalg.norm(ey)
        return np.array([ex, ey, np.cross(ex, ey)])

    def end_releases(self, e: Element) -> tuple[dict[str, float], dict[str, float]]:
        """The released rotations of element `e`'s two ends, {rotation: stiffness N m/rad}
        each (empty: rigid): a planar element's ``release_i`` / ``release_j`` in the layout's
        one hinge rotation, a space element's ``releases_i`` / ``releases_j``."""
        if len(self.layout.hinges) == 1 and not (e.releases_i or e.releases_j):
            h = self.layout.hinges[0]
            return ({} if e.release_i is None else {h: e.release_i}), ({} if e.release_j is None else {h: e.release_j})
        return dict(e.releases_i), dict(e.releases_j)

    def element_modulus_pa(self, element_id: int) -> float:
        """Young's modulus of an element (Pa): its own if updated, else its material's."""
        e = self.element(element_id)
        if e.youngs_modulus_pa is not None:
            return e.youngs_modulus_pa
        return self.materials[e.material].youngs_modulus_pa

    def total_mass_kg(self) -> float:
        """Mass of all elements and lumped masses (kg)."""
        m = 0.0
        for e in self.elements:
            m += (self.materials[e.material].density_kg_m3 * self.sections[e.section].area_m2
                  * self.element_length_m(e.id))
        return m + sum(lm.mass_kg for lm in self.masses)

    def joints(self) -> tuple[int, ...]:
        """Nodes where more than two element ends meet (where members join)."""
        count: dict[int, int] = {}
        for e in self.elements:
            for n in (e.node_i, e.node_j):
                count[n] = count.get(n, 0) + 1
        return tuple(n for n, c in count.items() if c > 2)

    def replace(self, **changes: Any) -> "FrameModel":
        """A copy with some fields changed (validated again; an element kept from this model,
        with the same nodes and layout, only for the tables it names: validate.py)."""
        token = _REPLACING.set(self)
        try:
            return dataclasses.replace(self, **changes)
        finally:
            _REPLACING.reset(token)

    def with_element_moduli(self, moduli_pa: dict[int, float]) -> "FrameModel":
        """A copy whose listed elements have their own modulus (an updated model)."""
        elements = tuple(
            dataclasses.replace(e, youngs_modulus_pa=float(moduli_pa[e.id])) if e.id in moduli_pa else e
            for e in self.elements
        )
        unknown = set(moduli_pa) - set(self.element_ids)
        if unknown:
            raise KeyError(f"model {self.name!r} has no element(s) {sorted(unknown)}")
        return self.replace(elements=elements)
