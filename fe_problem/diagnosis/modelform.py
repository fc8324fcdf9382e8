"""Model-form classes: the model's geometry, sections or supports are wrong, not its physics.

A node a centimetre off its true place, or a member drawn a few per cent too deep, moves the
modes as a crack, a mass or a spring would; fitted by those candidates it becomes confident
local physics. These classes are the model-form alternatives at every element and node, screened by one
step each, the best few fitted (core.score_classes), and scored by their evidence beside the
answer: when one explains the data about as well (within a
factor of 10 of the answer's evidence) or better, the record says the named cause may be a
model-form error.

- ``member_depth`` of an element: its rectangular section's depth times (1 - a) (thinner) or
  (1 + a) (deeper), so its area and mass per length times the same factor and its inertia by
  its cube; a in [0, 0.5].
- ``node_position`` of a node: moved by a metres in +x, -x, +y or -y, a up to `MAX_MOVE` of the
  shortest member at the node.
- ``support_condition`` of a support, per direction of the layout: a held direction released
  onto a spring (a fixed base really pinned), a free rotation held by one (a pinned base really
  fixed); supports.py, on planar and space models.

Each size is a model of its own (the geometry enters the element matrices nonlinearly), so each
is screened by one step and only the most promising are fitted, coarsely.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..model import FrameModel
from .candidates import Candidate, Setting, solve_model
from .fit import look_along
from .screening import screen_steps
from .supports import support_candidates

#: A node may move up to this fraction of its shortest member's length.
MAX_MOVE = 0.2
GRID = np.concatenate([[0.0], np.geomspace(0.005, 1.0, 9)])


def _forward(st: Setting, build, elements):
    """The forward of a candidate whose sizes `build` models that differ from `st.model` only in
    the matrices of `elements` (ids; `solve_model` builds them from the Setting's system)."""
    def forward(a):
        a = np.atleast_1d(np.asarray(a, dtype=float))
        out = [solve_model(build(float(v)), st, elements) for v in a]
        return np.concatenate([o[0] for o in out]), np.concatenate([o[1] for o in out])
    return forward


def member_depth(model: FrameModel, element: int, factor: float) -> FrameModel:
    """`model` with one element's section `factor` times as deep (area x f, inertia x f^3)."""
    e = model.element(element)
    sec = model.sections[e.section]
    new = dataclasses.replace(sec, area_m2=factor * sec.area_m2, inertia_m4=factor**3 * sec.inertia_m4)
    name = f"{e.section}*depth@{element}"
    return model.replace(sections={**model.sections, name: new},
                         elements=tuple(dataclasses.replace(x, section=name) if x.id == element else x
                                        for x in model.elements))


def moved_node(model: FrameModel, node: int, dx: float, dy: float) -> FrameModel:
    """`model` with one node moved by (dx, dy) metres."""
    return model.replace(nodes=tuple(dataclasses.replace(n, x=n.x + dx, y=n.y + dy) if n.id == node else n
                                     for n in model.nodes))


def model_form_candidates(st: Setting, places: list[dict] | None = None) -> list[Candidate]:
    """The model-form candidates at the elements and nodes of `places` (the causes' locations);
    None: at every element and node. A member's depth and a node's position on planar models only
    (moves in x and y, a rectangular depth in the frame's plane); the support conditions
    (supports.py) on any model, last."""
    model = st.model
    if model.layout.dimension != 2:
        return support_candidates(st, None if places is None else _places_nodes(model, places))
    elements, nodes = [], []
    if places is None:
        elements, nodes = list(model.element_ids), list(model.node_ids)
    for loc in places or ():
        if loc and loc.get("node") in model.node_ids:  # a joint's element is its node's
            nodes.append(loc["node"])
        elif loc and loc.get("element") in model.element_ids:
            e = model.element(loc["element"])
            elements.append(e.id)
            nodes += [e.node_i, e.node_j]
    fixed = {s.node for s in model.supports if {"x", "y"} <= set(s.directions)}
    out = []
    for element in dict.fromkeys(elements):
        for sign, what in ((-1.0, "thinner"), (1.0, "deeper")):
            def estimate(a, s, sign=sign):
                return {"depth_factor": 1.0 + sign * a}

            build = (lambda v, element=element, sign=sign: member_depth(model, element, 1.0 + sign * v))
            term = ((lambda element=element, sign=sign: st.local.depth(element, sign))
                    if st.local.plain_beam(element) else None)  # the first-order screen's (local.py)
            out.append(Candidate("member_depth", {"element": element}, 0.5, 0.5 * GRID,
                                 _forward(st, build, (element,)), estimate,
                                 build, step=0.005, meta={"profile": what}, term=term))
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
            out.append(Candidate("node_position", {"node": node}, upper, upper * GRID, _forward(st, build, at),
                                 estimate,
                                 build, step=0.005 * upper, meta={"profile": f"{'+' if sign > 0 else '-'}{d}"},
                                 term=term))
    return out + support_candidates(st, None if places is None else set(nodes))


def screen_forms(obs, base, setting: Setting, forms: list[Candidate]) -> list[tuple[float, float]]:
    """(chi^2 drop, a) of each model-form candidate, by which the best are chosen to be fitted: one
    exact step each (`screening.screen_steps`), and for a support condition the larger of that and
    a look along its grid (`fit.look_along`, one batched solve of its affine system). A support
    released from fixed towards pinned is far from linear in its size: a shear building's pinned
    column base screened at 0 by the step, and was never fitted, where its fit reached chi^2 56
    against the 100 of the two causes the search named. On the sparse path too (the step there is
    first order, a support's by its reaction term, supports.py): without the look the shipped space
    frame's pinned corner base was not among the 6 fitted. The look builds and solves each
    support's own system: a few seconds for the 12 supports of a 1,092-DOF frame."""
    steps = screen_steps(obs, base, setting, forms)
    return [max(step, look_along(obs, c, base), key=lambda x: x[0]) if c.kind == "support_condition" else step
            for c, step in zip(forms, steps)]


def _places_nodes(model: FrameModel, places: list[dict]) -> set[int]:
    """The nodes of `places`: a node's own, an element's two."""
    out = set()
    for loc in places or ():
        if loc and loc.get("node") in model.node_ids:
            out.add(loc["node"])
        elif loc and loc.get("element") in model.element_ids:
            e = model.element(loc["element"])
            out |= {e.node_i, e.node_j}
    return out
