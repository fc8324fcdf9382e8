"""The degrees of freedom of a model's nodes: which there are, their names and their order.

A `DofLayout` is the one place that knows how many DOFs a node has and what they are called.
Everything else (assembly, element formulations, data files, drawings) asks the layout:
``model.layout.index(node, "y")``, ``layout.translations``, ``layout.hinges``,
``layout.rigid_motions(model.coordinates)``. The planar frame (x, y, rz; nodes in the x-y
plane) and the space frame (x, y, z, rx, ry, rz) are two layouts; no code outside the layout
and the element formulations assumes a node has x, y and rz.

Global nodal DOFs are node-major: (node 1: every name in order), (node 2: ...), ...
Translations are in metres, rotations in radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Every nodal DOF a layout can name, in the order of the 6 values per node of 3-D data
#: files (UFF dataset 55, data characteristic 3): 3 translations, then 3 rotations.
SPATIAL = ("x", "y", "z", "rx", "ry", "rz")


#: The axis each rotation turns about (a unit vector), and each translation moves along.
AXIS = {"x": 0, "y": 1, "z": 2, "rx": 0, "ry": 1, "rz": 2}


@dataclass(frozen=True)
class DofLayout:
    """The DOFs of every node of a model, in this order.

    names: the DOF names of one node (a subset of `SPATIAL`), in their order within the node;
    translations: the names that are displacements (m), the rest are rotations (rad);
    hinges: the rotations an element end may be released in from its node (its own end
    rotation tied to the node's by a rotational spring): the planar frame's ("rz",), the space
    frame's ("rx", "ry", "rz") (torsion and both bending rotations);
    dimension: 2 (nodes in the x-y plane, coordinates (x, y)) or 3 (coordinates (x, y, z)).
    """

    names: tuple[str, ...]
    translations: tuple[str, ...]
    hinges: tuple[str, ...]
    dimension: int = 2

    def __post_init__(self) -> None:
        unknown = [n for n in self.names if n not in SPATIAL]
        if (unknown or not set(self.translations) <= set(self.names) or not self.hinges
                or not set(self.hinges) <= set(self.rotations) or self.dimension not in (2, 3)
                or any(AXIS[t] >= self.dimension for t in self.translations)):
            raise ValueError(f"inconsistent DOF layout {self}")

    @property
    def planar(self) -> bool:
        """Whether the nodes lie in the x-y plane (`dimension` 2): the classes the diagnosis reads
        from x and y (a node's moves, a section's depth in the frame's plane, storeys and trends)
        are built on such a layout only. The one place the diagnosis asks the dimension."""
        return self.dimension == 2

    @property
    def per_node(self) -> int:
        """How many DOFs one node has."""
        return len(self.names)

    @property
    def rotations(self) -> tuple[str, ...]:
        """The names that are rotations (rad), in their order within the node."""
        return tuple(n for n in self.names if n not in self.translations)

    @property
    def rotation(self) -> str:
        """The one hinge rotation of a layout that has one (the planar frame's "rz");
        ValueError for a layout with several (use `hinges`)."""
        if len(self.hinges) != 1:
            raise ValueError(f"the layout {self.names} has {len(self.hinges)} hinge rotations {self.hinges}: "
                             "use layout.hinges")
        return self.hinges[0]

    def n_dof(self, n_nodes: int) -> int:
        """How many nodal DOFs `n_nodes` nodes have."""
        return self.per_node * n_nodes

    def position(self, name: str) -> int:
        """Position of DOF `name` within a node (0 .. per_node - 1); KeyError if unknown."""
        if name not in self.names:
            raise KeyError(f"unknown direction {name!r}; use one of {self.names}")
        return self.names.index(name)

    def node_dofs(self, node_position: int) -> tuple[int, ...]:
        """Global indices of every DOF of the node at `node_position` (0-based, model order)."""
        base = self.per_node * node_position
        return tuple(range(base, base + self.per_node))

    def index(self, node_position: int, name: str) -> int:
        """Global index of DOF `name` of the node at `node_position`."""
        return self.per_node * node_position + self.position(name)

    @property
    def translation_positions(self) -> tuple[int, ...]:
        """Positions of the translations within a node."""
        return tuple(self.names.index(t) for t in self.translations)

    @property
    def rotation_position(self) -> int:
        """Position of the one hinge rotation within a node (`rotation`)."""
        return self.names.index(self.rotation)

    @property
    def n_rigid_motions(self) -> int:
        """How many rigid-body motions a free body of this layout has (planar 3, space 6)."""
        return len(self.translations) + len(self.rotations)

    def rigid_motions(self, coords: np.ndarray) -> np.ndarray:
        """The rigid-body motions of nodes at coordinates `coords` (n_nodes, dimension) in
        metres: (n_nodes * per_node, n_rigid_motions), node-major. One column per translation
        (1 along its axis), then one per rotation about its axis through the origin (the
        rotation 1, each translation the component of omega x r: about z, u_x = -y, u_y = x;
        about x, u_y = -z, u_z = y; about y, u_z = -x, u_x = z)."""
        coords = np.asarray(coords, dtype=float)
        if coords.ndim != 2 or coords.shape[1] != self.dimension:
            raise ValueError(f"coordinates must be (n_nodes, {self.dimension}), got {coords.shape}")
        n = len(coords)
        r = np.zeros((n, 3))
        r[:, : self.dimension] = coords
        out = np.zeros((n, self.per_node, self.n_rigid_motions))
        for col, t in enumerate(self.translations):
            out[:, self.position(t), col] = 1.0
        for col, rot in enumerate(self.rotations, start=len(self.translations)):
            a = AXIS[rot]
            b, c = (a + 1) % 3, (a + 2) % 3      # omega = e_a: (omega x r)_b = -r_c, (omega x r)_c = r_b
            for axis, value in ((b, -r[:, c]), (c, r[:, b])):
                name = SPATIAL[axis]
                if name in self.translations:
                    out[:, self.position(name), col] = value
            out[:, self.position(rot), col] = 1.0
        return out.reshape(n * self.per_node, self.n_rigid_motions)

    def spatial_column(self, name: str) -> int:
        """Column of DOF `name` among the 6 spatial values of a node (x, y, z, rx, ry, rz)."""
        return SPATIAL.index(name)


#: The planar frame: translations x, y and the rotation rz about the out-of-plane axis.
PLANAR_FRAME = DofLayout(names=("x", "y", "rz"), translations=("x", "y"), hinges=("rz",), dimension=2)

#: The space frame: six DOFs per node, x, y, z, rx, ry, rz, nodes anywhere in space. An element
#: end may be released in any of its three rotations, named in the element's local axes (rx
#: torsion, ry and rz bending; docs/model-format.md).
SPACE_FRAME = DofLayout(names=SPATIAL, translations=("x", "y", "z"), hinges=("rx", "ry", "rz"), dimension=3)

#: The layout of a model file without "dimension" (every planar model).
DEFAULT_LAYOUT = PLANAR_FRAME

#: The layout of each value of a model file's "dimension".
LAYOUTS = {2: PLANAR_FRAME, 3: SPACE_FRAME}
