"""Large models in one call: every element split into equal parts, and regular multi-bay
multi-storey planar frames and space frames. Both build the whole model at once (no copy per new element), so a
model of thousands of nodes takes milliseconds; the result is validated like any other."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..dofs import PLANAR_FRAME, SPACE_FRAME
from ..limits import MAX_SPARSE_DOFS
from .edits import part_fields
from .types import Element, FrameModel, LumpedMass, Material, Node, Section, Support

#: Base fixity of `regular_frame`: the directions fixed at every base node.
BASES = {"fixed": PLANAR_FRAME.names, "pinned": PLANAR_FRAME.translations}


def split_elements(model: FrameModel, parts: int) -> FrameModel:
    """A copy with every element split into `parts` equal elements (``parts = 1``: `model`).

    Numbering is what splitting the elements one after another with `split_element` gives:
    element by element in model order, the new nodes (from node_i to node_j) and the new
    elements take the next free ids; the first part keeps the element's id and its release at
    node_i, the last part its release at node_j; a crack stays in the part that holds it, a weak
    zone is cut to the parts it spans (`edits.part_fields`).
    Masses, springs, supports and measured DOFs stay on their nodes."""
    if isinstance(parts, bool) or not isinstance(parts, (int, np.integer)) or parts < 1:
        raise ValueError(f"parts must be a whole number >= 1, got {parts!r}")
    parts = int(parts)
    if parts == 1:
        return model
    n_nodes = len(model.nodes) + len(model.elements) * (parts - 1)
    _check_size(n_nodes * model.layout.per_node - sum(len(s.directions) for s in model.supports),
                f"{model.name} with every element in {parts} parts: {n_nodes} nodes")
    at = model.coordinates
    a = np.array([at[model.node_position(e.node_i)] for e in model.elements], dtype=float)
    b = np.array([at[model.node_position(e.node_j)] for e in model.elements], dtype=float)
    pts = np.empty((parts - 1,) + a.shape)
    prev = a
    for k in range(parts - 1):  # the same floating-point steps as repeated split_element calls
        prev = pts[k] = prev + (1.0 / (parts - k)) * (b - prev)
    n_el, next_node, next_el = len(model.elements), max(model.node_ids) + 1, max(model.element_ids) + 1
    node_ids = next_node + np.arange(n_el * (parts - 1)).reshape(n_el, parts - 1)
    el_ids = next_el + np.arange(n_el * (parts - 1)).reshape(n_el, parts - 1)
    nodes, elements = list(model.nodes), []
    for i, e in enumerate(model.elements):
        ends = [e.node_i, *map(int, node_ids[i]), e.node_j]
        nodes.extend(Node(int(node_ids[i, k]), *map(float, pts[k, i])) for k in range(parts - 1))
        for k in range(parts):
            elements.append(dataclasses.replace(
                e, id=e.id if k == 0 else int(el_ids[i, k - 1]), node_i=ends[k], node_j=ends[k + 1],
                release_i=e.release_i if k == 0 else None, release_j=e.release_j if k == parts - 1 else None,
                releases_i=e.releases_i if k == 0 else (), releases_j=e.releases_j if k == parts - 1 else (),
                **part_fields(e, k / parts, (k + 1) / parts)))
    return model.replace(nodes=tuple(nodes), elements=tuple(elements))


def regular_frame(bays: int, storeys: int, bay_width_m: float = 6.0, storey_height_m: float = 3.0, *,
                  column: Section = Section(1.0e-2, 1.0e-4), beam: Section = Section(8.0e-3, 2.0e-4),
                  material: Material = Material(2.1e11, 7850.0, 0.3), base: str = "fixed",
                  floor_mass_kg: float = 0.0, name: str | None = None, description: str | None = None) -> FrameModel:
    """A regular planar frame of `bays` bays and `storeys` storeys (one element per member).

    Nodes are numbered storey by storey from the base, left to right: node
    ``s * (bays + 1) + c + 1`` at (c * bay_width_m, s * storey_height_m). Per storey, the
    columns (left to right), then the beams (left to right), take the next element ids.
    Sections ``column`` and ``beam``, one ``material`` ("steel" by default: E 210 GPa,
    7850 kg/m^3); base nodes `base` ("fixed" or "pinned", `BASES`); a lumped mass
    `floor_mass_kg` (kg) at every node above the base; measured DOFs x and y at those nodes."""
    for value, what in ((bays, "bays"), (storeys, "storeys")):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ValueError(f"{what} must be a whole number >= 1, got {value!r}")
    for value, what in ((bay_width_m, "bay width"), (storey_height_m, "storey height")):
        if not np.isfinite(value) or value <= 0:
            raise ValueError(f"{what} must be a positive number of metres, got {value!r}")
    if base not in BASES:
        raise ValueError(f"base must be one of {', '.join(BASES)}, got {base!r}")
    if not np.isfinite(floor_mass_kg) or floor_mass_kg < 0:
        raise ValueError(f"floor mass must be a number of kg >= 0, got {floor_mass_kg!r}")
    per = bays + 1
    _check_size(per * storeys * PLANAR_FRAME.per_node, f"a frame of {bays} bays and {storeys} storeys: "
                f"{per * (storeys + 1)} nodes")
    nodes = tuple(Node(s * per + c + 1, c * bay_width_m, s * storey_height_m)
                  for s in range(storeys + 1) for c in range(per))
    elements, eid = [], 1
    for s in range(storeys):
        for c in range(per):
            elements.append(Element(eid, s * per + c + 1, (s + 1) * per + c + 1, "column", "steel"))
            eid += 1
        for c in range(bays):
            elements.append(Element(eid, (s + 1) * per + c + 1, (s + 1) * per + c + 2, "beam", "steel"))
            eid += 1
    upper = [n.id for n in nodes[per:]]
    return FrameModel(
        name=name or f"frame{bays}x{storeys}", nodes=nodes, materials={"steel": material},
        sections={"column": column, "beam": beam}, elements=tuple(elements),
        masses=tuple(LumpedMass(n, float(floor_mass_kg)) for n in upper) if floor_mass_kg > 0 else (),
        supports=tuple(Support(c + 1, BASES[base]) for c in range(per)),
        measured_dofs=tuple((n, d) for n in upper for d in PLANAR_FRAME.translations),
        description=description if description is not None else
        f"regular {bays}-bay {storeys}-storey frame, {bay_width_m:g} m bays, {storey_height_m:g} m storeys, {base} base")


#: Base fixity of `regular_frame_3d`: the directions fixed at every base node.
BASES_3D = {"fixed": ("x", "y", "z", "rx", "ry", "rz"), "pinned": ("x", "y", "z")}

#: The default sections of `regular_frame_3d`: a European HEB 300 column and IPE 400 beam
#: (areas, second moments of area about the strong (iy) and weak (iz) axes, torsion constants
#: from the steel tables).
HEB300 = Section(1.491e-2, iy_m4=2.517e-4, iz_m4=8.563e-5, j_m4=1.850e-6)
IPE400 = Section(8.446e-3, iy_m4=2.313e-4, iz_m4=1.318e-5, j_m4=5.108e-7)
#: Structural steel: E 210 GPa, G 81 GPa, 7850 kg/m^3.
STEEL_3D = Material(2.1e11, 7850.0, 0.3, shear_modulus_pa=8.1e10)


def regular_frame_3d(bays_x: int, bays_y: int, storeys: int, bay_width_x_m: float = 6.0,
                     bay_width_y_m: float = 6.0, storey_height_m: float = 3.0, *, column: Section = HEB300,
                     beam: Section = IPE400, material: Material = STEEL_3D, base: str = "fixed",
                     floor_mass_kg: float = 0.0, name: str | None = None,
                     description: str | None = None) -> FrameModel:
    """A regular space frame of `bays_x` by `bays_y` bays and `storeys` storeys (one element per
    member), z vertical.

    Nodes are numbered storey by storey from the base, row by row in y, along x within a row:
    node ``s * (bays_x + 1) * (bays_y + 1) + r * (bays_x + 1) + c + 1`` at (c * bay_width_x_m,
    r * bay_width_y_m, s * storey_height_m). Per storey, the columns (in node order), then the
    beams along x (row by row), then the beams along y (column line by column line) take the
    next element ids. Columns have orientation (1, 0, 0): their strong axis (``iy_m4``) resists
    bending in x; beams (0, 0, 1): strong axis vertical. Sections `column` and `beam` (default
    HEB 300 and IPE 400), one `material` ("steel"); base nodes `base` ("fixed" or "pinned",
    `BASES_3D`); a lumped mass `floor_mass_kg` (kg) at every node above the base; measured DOFs
    x and y at those nodes. Built in linear time (about 0.1 s per 10,000 DOFs)."""
    for value, what in ((bays_x, "bays in x"), (bays_y, "bays in y"), (storeys, "storeys")):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ValueError(f"{what} must be a whole number >= 1, got {value!r}")
    for value, what in ((bay_width_x_m, "bay width in x"), (bay_width_y_m, "bay width in y"),
                        (storey_height_m, "storey height")):
        if not np.isfinite(value) or value <= 0:
            raise ValueError(f"{what} must be a positive number of metres, got {value!r}")
    if base not in BASES_3D:
        raise ValueError(f"base must be one of {', '.join(BASES_3D)}, got {base!r}")
    if not np.isfinite(floor_mass_kg) or floor_mass_kg < 0:
        raise ValueError(f"floor mass must be a number of kg >= 0, got {floor_mass_kg!r}")
    nx, ny = bays_x + 1, bays_y + 1
    per = nx * ny
    _check_size(per * storeys * SPACE_FRAME.per_node, f"a space frame of {bays_x} x {bays_y} bays and {storeys} "
                f"storeys: {per * (storeys + 1)} nodes")

    def node_id(s: int, r: int, c: int) -> int:
        return s * per + r * nx + c + 1

    nodes = tuple(Node(node_id(s, r, c), c * bay_width_x_m, r * bay_width_y_m, s * storey_height_m)
                  for s in range(storeys + 1) for r in range(ny) for c in range(nx))
    up, flat = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)
    members = []
    for s in range(storeys):
        members += [(node_id(s, r, c), node_id(s + 1, r, c), "column", up) for r in range(ny) for c in range(nx)]
        members += [(node_id(s + 1, r, c), node_id(s + 1, r, c + 1), "beam", flat)
                    for r in range(ny) for c in range(bays_x)]
        members += [(node_id(s + 1, r, c), node_id(s + 1, r + 1, c), "beam", flat)
                    for c in range(nx) for r in range(bays_y)]
    elements = tuple(Element(k + 1, a, b, sec, "steel", orientation=o) for k, (a, b, sec, o) in enumerate(members))
    upper = [n.id for n in nodes[per:]]
    return FrameModel(
        name=name or f"frame{bays_x}x{bays_y}x{storeys}", nodes=nodes, materials={"steel": material},
        sections={"column": column, "beam": beam}, elements=elements,
        masses=tuple(LumpedMass(n, float(floor_mass_kg)) for n in upper) if floor_mass_kg > 0 else (),
        supports=tuple(Support(n.id, BASES_3D[base]) for n in nodes[:per]),
        measured_dofs=tuple((n, d) for n in upper for d in ("x", "y")),
        description=description if description is not None else
        f"regular {bays_x} x {bays_y}-bay {storeys}-storey space frame, {bay_width_x_m:g} m x {bay_width_y_m:g} m "
        f"bays, {storey_height_m:g} m storeys, {base} base",
        layout=SPACE_FRAME)


def _check_size(n_free: int, what: str) -> None:
    """ValueError before a model is built whose free DOFs no solver path takes (`MAX_SPARSE_DOFS`)."""
    if n_free > MAX_SPARSE_DOFS:
        raise ValueError(f"{what}, about {n_free} free DOFs: more than the {MAX_SPARSE_DOFS} any solver path takes "
                         "(fe_problem.limits.MAX_SPARSE_DOFS); generate a smaller model")


__all__ = ["BASES", "BASES_3D", "HEB300", "IPE400", "STEEL_3D", "regular_frame", "regular_frame_3d", "split_elements"]
