"""Large models in one call: every element split into equal parts, and regular multi-bay
multi-storey planar frames. Both build the whole model at once (no copy per new element), so a
model of thousands of nodes takes milliseconds; the result is validated like any other."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..dofs import PLANAR_FRAME
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


__all__ = ["BASES", "regular_frame", "split_elements"]
