"""``support_condition`` of a support, per direction of the layout: a held direction released onto a
spring (a fixed base really pinned), a free rotation held by one (a pinned base really fixed);
supports.py builds them (`support_candidates`: its physics, the reaction term and the spring
scale, stay there), reached through this spec, on planar and space models. A model-form class (modelform.py)."""

from __future__ import annotations

from ..setting import Candidate, Setting
from ..supports import support_candidates
from .spec import KindSpec


def generate(st: Setting) -> list[Candidate]:
    """At every support."""
    return support_candidates(st)


def at(st: Setting, elements, nodes) -> list[Candidate]:
    """At the supports of `nodes` only (a cause's places)."""
    return support_candidates(st, set(nodes))


def variants(st: Setting, cand: Candidate) -> int:
    """Its row's conditions: the candidates `support_candidates` builds at its node."""
    node = cand.location["node"]
    return max(1, sum(c.location["node"] == node for c in support_candidates(st, {node})))


def check(model, loc: dict, estimate: dict) -> str | None:
    """A support released onto a spring so soft it would hardly hold (supports.py's ``free``)."""
    if estimate.get("condition") != "free":
        return None
    return (f"the support at node {loc.get('node')} would hold in {loc.get('direction')} with "
            f"{100 * estimate['fixity']:.2g} % fixity (a spring {estimate['stiffness_ratio']:.3g} times the members' "
            f"stiffness there): a support that is hardly there, not a soft support; check the model's supports")


SPEC = KindSpec("support_condition", "model_form", ("node", "direction"), generate, variants=variants, check=check,
                term="reaction (supports.reaction_term)", at=at,
                doc="a support released onto a spring, or a free rotation held")
