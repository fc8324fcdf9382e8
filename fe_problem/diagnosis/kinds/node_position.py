"""``node_position`` of a node: moved by a metres in +x, -x, +y or -y, a up to `MAX_MOVE` of the
shortest member at the node. A model-form class (modelform.py), planar models only; a node held in
x and y by a support is not moved."""

from __future__ import annotations

import dataclasses

from ...model import FrameModel
from ..setting import Candidate, Setting
from .member_depth import GRID, models_forward
from .spec import KindSpec

#: A node may move up to this fraction of its shortest member's length.
MAX_MOVE = 0.2


def moved_node(model: FrameModel, node: int, dx: float, dy: float) -> FrameModel:
    """`model` with one node moved by (dx, dy) metres."""
    return model.replace(nodes=tuple(dataclasses.replace(n, x=n.x + dx, y=n.y + dy) if n.id == node else n
                                     for n in model.nodes))


def candidates(st: Setting, nodes) -> list[Candidate]:
    """The four moves of each node of `nodes` (ids, in order) that no support holds in x and y."""
    model = st.model
    if not model.layout.planar:
        return []
    fixed = {s.node for s in model.supports if {"x", "y"} <= set(s.directions)}
    out = []
    for node in dict.fromkeys(nodes):
        if node in fixed:
            continue
        at = tuple(e.id for e in model.elements_at(node))
        lengths = [model.element_length_m(e) for e in at]
        if not lengths:
            continue
        upper = MAX_MOVE * min(lengths)
        plain = st.local.plain_node(node)
        for d, sign in (("x", 1.0), ("x", -1.0), ("y", 1.0), ("y", -1.0)):
            def estimate(a, s, d=d, sign=sign):
                return {"move_m": sign * a, "direction": d}

            build = (lambda v, node=node, d=d, sign=sign:
                     moved_node(model, node, sign * v if d == "x" else 0.0, sign * v if d == "y" else 0.0))
            term = (lambda node=node, d=d, sign=sign: st.local.node_move(node, d, sign)) if plain else None
            out.append(Candidate("node_position", {"node": node}, upper, upper * GRID, models_forward(st, build, at),
                                 estimate,
                                 build, step=0.005 * upper, meta={"profile": f"{'+' if sign > 0 else '-'}{d}"},
                                 term=term))
    return out


def generate(st: Setting) -> list[Candidate]:
    """At every node."""
    return candidates(st, st.model.node_ids)


def variants(st: Setting, cand: Candidate) -> int:
    """Its row's moves: each translation of the layout, either sign."""
    return 2 * len(st.model.layout.translations)


def at(st: Setting, elements, nodes) -> list[Candidate]:
    """At `nodes` only (a cause's places)."""
    return candidates(st, nodes)


SPEC = KindSpec("node_position", "model_form", ("node",), generate, variants=variants, term="node_move",
                doc="a node moved in the frame's plane (planar)", at=at)
