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

from .fit import look_along
from .kinds import class_candidates
from .kinds.member_depth import GRID, member_depth, models_forward as _forward  # noqa: F401 (named here)
from .kinds.node_position import MAX_MOVE, moved_node  # noqa: F401 (named here)
from .screening import screen_steps
from .setting import Candidate, Setting


def model_form_candidates(st: Setting, places: list[dict] | None = None) -> list[Candidate]:
    """The model-form candidates at the elements and nodes of `places` (the causes' locations);
    None: at every element and node. Every registered model-form kind's, in registration order
    (`kinds.class_candidates`): a member's depth and a node's position (kinds/member_depth.py,
    kinds/node_position.py: planar models only, moves in x and y, a rectangular depth in the frame's
    plane), the support conditions (kinds/support_condition.py, supports.py) on any model, last."""
    model = st.model
    if places is None:
        return class_candidates(st, "model_form")
    elements, nodes = [], []
    for loc in places:
        if loc and loc.get("node") in model.node_ids:  # a joint's element is its node's
            nodes.append(loc["node"])
        elif loc and loc.get("element") in model.element_ids:
            e = model.element(loc["element"])
            elements.append(e.id)
            nodes += [e.node_i, e.node_j]
    return class_candidates(st, "model_form", elements, nodes)


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
