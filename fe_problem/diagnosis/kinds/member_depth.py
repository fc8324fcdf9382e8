"""``member_depth`` of an element: its rectangular section's depth times (1 - a) (thinner) or (1 + a)
(deeper), so its area and mass per length times the same factor and its inertia by its cube; a in
[0, 0.5]. A model-form class (modelform.py): each size a model of its own, planar models only (a
rectangular depth in the frame's plane)."""

from __future__ import annotations

import dataclasses

import numpy as np

from ...model import FrameModel
from ..setting import Candidate, Setting, solve_model
from .spec import KindSpec

#: The sizes a model-form candidate tries, times its upper bound.
GRID = np.concatenate([[0.0], np.geomspace(0.005, 1.0, 9)])


def models_forward(st: Setting, build, elements):
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


def candidates(st: Setting, elements) -> list[Candidate]:
    """The thinner and deeper candidates of each element of `elements` (ids, in order; none on a
    layout whose sections have no depth in the frame's plane)."""
    model = st.model
    if not model.layout.planar:
        return []
    out = []
    for element in dict.fromkeys(elements):
        for sign, what in ((-1.0, "thinner"), (1.0, "deeper")):
            def estimate(a, s, sign=sign):
                return {"depth_factor": 1.0 + sign * a}

            build = (lambda v, element=element, sign=sign: member_depth(model, element, 1.0 + sign * v))
            term = ((lambda element=element, sign=sign: st.local.depth(element, sign))
                    if st.local.plain_beam(element) else None)  # the first-order screen's (local.py)
            out.append(Candidate("member_depth", {"element": element}, 0.5, 0.5 * GRID,
                                 models_forward(st, build, (element,)), estimate,
                                 build, step=0.005, meta={"profile": what}, term=term))
    return out


def generate(st: Setting) -> list[Candidate]:
    """At every element."""
    return candidates(st, st.model.element_ids)


def _two(st, cand) -> int:
    return 2


def at(st: Setting, elements, nodes) -> list[Candidate]:
    """At `elements` only (a cause's places)."""
    return candidates(st, elements)


SPEC = KindSpec("member_depth", "model_form", ("element",), generate, variants=_two, term="depth",
                doc="a member's section thinner or deeper (planar)", at=at)
