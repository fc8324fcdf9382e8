"""Model edits: copies of a model with an effect added (a mass, a released or cracked
element end, a split element, another element formulation). Used to build truths and the
diagnosis' extensions; every result is validated again."""

from __future__ import annotations

import dataclasses

from .types import Element, FrameModel, LumpedMass, Node


def add_mass(model: FrameModel, node: int, mass_kg: float, inertia_kg_m2: float = 0.0) -> FrameModel:
    """A copy with a lumped mass added at `node`."""
    return model.replace(masses=model.masses + (LumpedMass(node, float(mass_kg), float(inertia_kg_m2)),))


def bending_hinges(model: FrameModel) -> tuple[str, ...]:
    """The rotations a joint's flexibility releases by default: the planar frame's one hinge
    rotation; a space frame's two bending rotations (local ry, rz; torsion stays rigid)."""
    hinges = model.layout.hinges
    return hinges if len(hinges) == 1 else tuple(h for h in hinges if h != "rx")


def _released(model: FrameModel, e: Element, end: str, stiffness: float | None, rotations=None) -> dict:
    """The `dataclasses.replace` fields that release end `end` ("i" or "j") of `e` in
    `rotations` (default `bending_hinges`) with `stiffness` (None: rigid again)."""
    if len(model.layout.hinges) == 1:
        if rotations is not None and tuple(rotations) != model.layout.hinges:
            raise ValueError(f"a planar element end is released in {model.layout.hinges[0]!r} only, got {rotations}")
        return {f"release_{end}": None if stiffness is None else float(stiffness)}
    if stiffness is None:
        return {f"releases_{end}": ()}
    released = dict(getattr(e, f"releases_{end}"))  # the end's other released rotations stay
    released.update((r, float(stiffness)) for r in (bending_hinges(model) if rotations is None else rotations))
    return {f"releases_{end}": tuple(released.items())}


def release_element_end(model: FrameModel, element_id: int, node: int, stiffness: float,
                        rotations=None) -> FrameModel:
    """A copy where the end of `element_id` at `node` is tied to it by a rotational spring of
    `stiffness` (N m/rad) in `rotations` (default: the planar frame's rz; a space frame's
    bending rotations, local ry and rz: `bending_hinges`)."""
    e = model.element(element_id)
    if node == e.node_i:
        new = dataclasses.replace(e, **_released(model, e, "i", stiffness, rotations))
    elif node == e.node_j:
        new = dataclasses.replace(e, **_released(model, e, "j", stiffness, rotations))
    else:
        raise KeyError(f"element {element_id} does not end at node {node}")
    return model.replace(elements=tuple(new if x.id == element_id else x for x in model.elements))


def part_fields(e: Element, lo: float, hi: float) -> dict:
    """The crack and weak-zone fields of the part [lo, hi] (fractions of the length from node_i)
    of element `e`, for `dataclasses.replace`: a crack stays in the part that holds it, at its
    position within that part; a weak zone is cut to the part (the same modulus ratio). A crack
    on the cut itself is refused (ValueError): it would be a joint between the parts."""
    out: dict = {}
    if e.crack_position is not None:
        c = e.crack_position
        if (lo > 0.0 and abs(c - lo) < 1e-9) or (hi < 1.0 and abs(c - hi) < 1e-9):
            raise ValueError(f"element {e.id}: its crack at {c:g} of the length falls on a boundary between parts "
                             "(it would be a joint there); cut the element elsewhere")
        inside = lo < c < hi
        out.update(crack_position=(c - lo) / (hi - lo) if inside else None,
                   crack_stiffness=e.crack_stiffness if inside else None)
    if e.weak_zone is not None:
        start, end, ratio = e.weak_zone
        a, b = max(start, lo), min(end, hi)
        out["weak_zone"] = ((a - lo) / (hi - lo), (b - lo) / (hi - lo), ratio) if b - a > 1e-12 else None
        if out["weak_zone"] is None:  # a part without the zone has no bending rotations of it either
            out["weak_zone_about"] = ()
    return out


def split_element(model: FrameModel, element_id: int, fraction: float,
                  rotational_stiffness: float | None = None) -> FrameModel:
    """A copy with element `element_id` split at `fraction` of its length from node_i.

    The first part keeps the element id, the second gets a new id (max + 1), the new node
    gets id max + 1. With `rotational_stiffness` the two parts are joined through a
    rotational spring (N m/rad; a space frame's in both bending rotations): the model of a
    crack at that point.
    """
    if not 0.0 < fraction < 1.0:
        raise ValueError(f"fraction must be inside (0, 1), got {fraction}")
    e = model.element(element_id)
    c = model.coordinates
    a, b = c[model.node_position(e.node_i)], c[model.node_position(e.node_j)]
    new_node = Node(max(model.node_ids) + 1, *(float(v) for v in a + fraction * (b - a)))
    first = dataclasses.replace(e, node_j=new_node.id, **_released(model, e, "j", None),
                                **part_fields(e, 0.0, fraction))
    second = dataclasses.replace(e, id=max(model.element_ids) + 1, node_i=new_node.id,
                                 **_released(model, e, "i", rotational_stiffness),
                                 **part_fields(e, fraction, 1.0))
    elements = []
    for x in model.elements:
        elements.extend([first, second] if x.id == element_id else [x])
    return model.replace(nodes=model.nodes + (new_node,), elements=tuple(elements))


def crack_element(model: FrameModel, element_id: int, position: float, stiffness: float) -> FrameModel:
    """A copy with a crack (rotational spring of `stiffness` N m/rad at `position`, a fraction
    of the length from node_i) inside element `element_id`, without remeshing."""
    e = model.element(element_id)
    new = dataclasses.replace(e, crack_position=float(position), crack_stiffness=float(stiffness))
    return model.replace(elements=tuple(new if x.id == element_id else x for x in model.elements))


def with_formulation(model: FrameModel, formulation: str) -> FrameModel:
    """A copy with every element using `formulation` ('euler-bernoulli' or 'timoshenko').
    Cracked elements and elements with a weak zone stay Euler-Bernoulli (they need that formulation)."""
    return model.replace(elements=tuple(e if e.crack_position is not None or e.weak_zone is not None
                                        else dataclasses.replace(e, formulation=formulation) for e in model.elements))
