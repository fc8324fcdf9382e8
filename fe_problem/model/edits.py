"""Model edits: copies of a model with an effect added (a mass, a released or cracked
element end, a split element, another element formulation). Used to build truths and the
diagnosis' extensions; every result is validated again."""

from __future__ import annotations

import dataclasses

from .types import FrameModel, LumpedMass, Node


def add_mass(model: FrameModel, node: int, mass_kg: float, inertia_kg_m2: float = 0.0) -> FrameModel:
    """A copy with a lumped mass added at `node`."""
    return model.replace(masses=model.masses + (LumpedMass(node, float(mass_kg), float(inertia_kg_m2)),))


def release_element_end(model: FrameModel, element_id: int, node: int, stiffness: float) -> FrameModel:
    """A copy where the end of `element_id` at `node` is tied to it by a rotational spring."""
    e = model.element(element_id)
    if node == e.node_i:
        new = dataclasses.replace(e, release_i=float(stiffness))
    elif node == e.node_j:
        new = dataclasses.replace(e, release_j=float(stiffness))
    else:
        raise KeyError(f"element {element_id} does not end at node {node}")
    return model.replace(elements=tuple(new if x.id == element_id else x for x in model.elements))


def split_element(model: FrameModel, element_id: int, fraction: float,
                  rotational_stiffness: float | None = None) -> FrameModel:
    """A copy with element `element_id` split at `fraction` of its length from node_i.

    The first part keeps the element id, the second gets a new id (max + 1), the new node
    gets id max + 1. With `rotational_stiffness` the two parts are joined through a
    rotational spring (N m/rad): the model of a crack at that point.
    """
    if not 0.0 < fraction < 1.0:
        raise ValueError(f"fraction must be inside (0, 1), got {fraction}")
    e = model.element(element_id)
    a, b = model.node(e.node_i), model.node(e.node_j)
    new_node = Node(max(model.node_ids) + 1, a.x + fraction * (b.x - a.x), a.y + fraction * (b.y - a.y))
    first = dataclasses.replace(e, node_j=new_node.id, release_j=None)
    second = dataclasses.replace(e, id=max(model.element_ids) + 1, node_i=new_node.id,
                                 release_i=rotational_stiffness, release_j=e.release_j)
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
