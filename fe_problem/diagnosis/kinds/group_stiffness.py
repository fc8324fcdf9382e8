"""``group_stiffness_loss`` / ``group_stiffness_gain`` of a group of members (a storey's columns, a
floor's beams: groups.py reads them from the geometry): every member's modulus times (1 -+ a), one
class with two sides. A distributed class, built through the registry (`kinds.class_candidates`) by
groups.distributed_candidates, which every distributed class of a setting shares its system with."""

from __future__ import annotations

from ..groups import distributed_candidates
from ..setting import Candidate, Setting
from .spec import KindSpec


def loss(st: Setting) -> list[Candidate]:
    """Every member group's loss."""
    return distributed_candidates(st, ("group_stiffness_loss",))


def gain(st: Setting) -> list[Candidate]:
    """Every member group's gain."""
    return distributed_candidates(st, ("group_stiffness_gain",))


LOSS = KindSpec("group_stiffness_loss", "distributed", ("group",), loss, sides="group_stiffness", side=-1,
                doc="a group of members softer")
GAIN = KindSpec("group_stiffness_gain", "distributed", ("group",), gain, sides="group_stiffness", side=1,
                doc="a group of members stiffer")
