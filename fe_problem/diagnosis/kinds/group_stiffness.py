"""``group_stiffness_loss`` / ``group_stiffness_gain`` of a group of members (a storey's columns, a
floor's beams: groups.py reads them from the geometry): every member's modulus times (1 -+ a), one
class with two sides. Built by groups.distributed_candidates (a distributed class)."""

from __future__ import annotations

from .spec import KindSpec

LOSS = KindSpec("group_stiffness_loss", "distributed", ("group",), sides="group_stiffness", side=-1,
                doc="a group of members softer")
GAIN = KindSpec("group_stiffness_gain", "distributed", ("group",), sides="group_stiffness", side=1,
                doc="a group of members stiffer")
