"""The degrees of freedom of a model's nodes: which there are, their names and their order.

A `DofLayout` is the one place that knows how many DOFs a node has and what they are called.
Everything else (assembly, element formulations, data files, drawings) asks the layout:
``model.layout.index(node, "y")``, ``layout.translations``, ``layout.rotation``. A space frame
is a new layout (x, y, z, rx, ry, rz) and new element formulations, not edits elsewhere.

Global nodal DOFs are node-major: (node 1: every name in order), (node 2: ...), ...
Translations are in metres, rotations in radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Every nodal DOF a layout can name, in the order of the 6 values per node of 3-D data
#: files (UFF dataset 55, data characteristic 3): 3 translations, then 3 rotations.
SPATIAL = ("x", "y", "z", "rx", "ry", "rz")


@dataclass(frozen=True)
class DofLayout:
    """The DOFs of every node of a model, in this order.

    names: the DOF names of one node (a subset of `SPATIAL`), in their order within the node;
    translations: the names that are displacements (m), the rest are rotations (rad);
    rotation: the rotation an element end may be released from its node in (a hinge).
    """

    names: tuple[str, ...]
    translations: tuple[str, ...]
    rotation: str

    def __post_init__(self) -> None:
        unknown = [n for n in self.names if n not in SPATIAL]
        if unknown or not set(self.translations) <= set(self.names) or self.rotation not in self.names:
            raise ValueError(f"inconsistent DOF layout {self}")

    @property
    def per_node(self) -> int:
        """How many DOFs one node has."""
        return len(self.names)

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
        """Position of the hinge rotation within a node."""
        return self.names.index(self.rotation)

    def rigid_motions(self, xy: np.ndarray) -> np.ndarray:
        """The rigid-body motions of nodes at coordinates `xy` (n_nodes, 2) in metres:
        (n_nodes * per_node, n_motions), node-major: for a planar frame the translations along
        x and y and the rotation about z through the origin (u_x = -y, u_y = x, rz = 1)."""
        if set(self.names) != {"x", "y", "rz"}:
            raise NotImplementedError(f"rigid motions of the layout {self.names}")
        xy = np.asarray(xy, dtype=float)
        n = len(xy)
        out = np.zeros((n, self.per_node, 3))
        ix, iy, ir = (self.position(d) for d in ("x", "y", "rz"))
        out[:, ix, 0] = 1.0
        out[:, iy, 1] = 1.0
        out[:, ix, 2], out[:, iy, 2], out[:, ir, 2] = -xy[:, 1], xy[:, 0], 1.0
        return out.reshape(n * self.per_node, 3)

    def spatial_column(self, name: str) -> int:
        """Column of DOF `name` among the 6 spatial values of a node (x, y, z, rx, ry, rz)."""
        return SPATIAL.index(name)


#: The planar frame: translations x, y and the rotation rz about the out-of-plane axis.
PLANAR_FRAME = DofLayout(names=("x", "y", "rz"), translations=("x", "y"), rotation="rz")

#: The layout of a model that does not name another (every model today).
DEFAULT_LAYOUT = PLANAR_FRAME
