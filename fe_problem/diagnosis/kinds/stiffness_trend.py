"""``stiffness_trend`` along the structure (groups.trends: the moduli change linearly with height or
along the span), either sign. Built by groups.distributed_candidates (a distributed class)."""

from __future__ import annotations

from .spec import KindSpec


def _two(st, cand) -> int:
    return 2


SPEC = KindSpec("stiffness_trend", "distributed", ("trend",), variants=_two, doc="a linear trend of the moduli")
