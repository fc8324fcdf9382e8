"""``stiffness_trend`` along the structure (groups.trends: the moduli change linearly with height or
along the span), either sign. A distributed class, built through the registry
(`kinds.class_candidates`) by groups.distributed_candidates."""

from __future__ import annotations

from ..groups import distributed_candidates
from ..setting import Candidate, Setting
from .spec import KindSpec


def generate(st: Setting) -> list[Candidate]:
    """Every trend, either sign."""
    return distributed_candidates(st, ("stiffness_trend",))


def _two(st, cand) -> int:
    return 2


SPEC = KindSpec("stiffness_trend", "distributed", ("trend",), generate, variants=_two,
                doc="a linear trend of the moduli")
